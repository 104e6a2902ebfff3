//! Where an axis's step edges come from. The board only sees [`StepSource`]: a stream of
//! absolute edge ticks plus the commanded speed.
//!
//! Moves the host commands (single axes and synchronous groups) are timed by the TDM
//! engine (DESIGN.md §3, seed 000 §1.2): one period calculator serves the whole group, the
//! group starts on one tick once every FIFO is primed, and a move that would underrun is
//! refused. With no underrun the engine's STEP rises are exactly `start + edge_i` of the
//! edge generator (tested below), so the board streams those edges in O(1) memory.

use crate::error::CtlError;
use multistep_core::tdm::{self, TdmConfig};
use multistep_core::{EdgeGenerator, MoveParams, MoveSpec, PlanError, Profile};

/// The edges of one move, in absolute board ticks.
pub trait StepSource: Send {
    /// The next edge's tick without consuming it.
    fn peek(&mut self) -> Option<u64>;
    /// Consumes the edge returned by `peek`.
    fn take(&mut self);
    /// Commanded speed (steps/s, unsigned) at `tick`.
    fn speed_at(&self, tick: u64) -> f64;
    /// Tick of the last edge.
    fn end_tick(&self) -> u64;
    fn steps_left(&self) -> u64;
    /// The tracking source behind this stream, if it is one (its rate can change).
    fn as_track(&mut self) -> Option<&mut crate::tracking::TrackSource> {
        None
    }
}

/// A move's edges straight from the exact edge generator, shifted to the start tick.
pub struct EdgeSource {
    gen: EdgeGenerator,
    start: u64,
    next: Option<u64>,
}

impl EdgeSource {
    pub fn new(profile: Profile, clock_hz: f64, start: u64) -> Result<EdgeSource, PlanError> {
        Ok(EdgeSource {
            gen: EdgeGenerator::new(profile, clock_hz)?,
            start,
            next: None,
        })
    }
}

impl StepSource for EdgeSource {
    fn peek(&mut self) -> Option<u64> {
        if self.next.is_none() {
            self.next = self.gen.next().map(|e| self.start + e);
        }
        self.next
    }
    fn take(&mut self) {
        self.next = None;
    }
    fn speed_at(&self, tick: u64) -> f64 {
        let t = tick.saturating_sub(self.start) as f64 / self.gen.clock();
        self.gen
            .profile()
            .velocity(t.min(self.gen.profile().duration()))
    }
    fn end_tick(&self) -> u64 {
        self.start + self.gen.last_edge_tick()
    }
    fn steps_left(&self) -> u64 {
        self.gen.remaining() + self.next.is_some() as u64
    }
}

/// The source of a stop that needs no steps: ends on its tick.
pub struct Stopped(pub u64);

impl StepSource for Stopped {
    fn peek(&mut self) -> Option<u64> {
        None
    }
    fn take(&mut self) {}
    fn speed_at(&self, _: u64) -> f64 {
        0.0
    }
    fn end_tick(&self) -> u64 {
        self.0
    }
    fn steps_left(&self) -> u64 {
        0
    }
}

/// Makes the step source of a planned move; the one place to swap in another engine.
pub fn start_move(
    profile: Profile,
    clock_hz: f64,
    start: u64,
) -> Result<Box<dyn StepSource>, PlanError> {
    Ok(Box::new(EdgeSource::new(profile, clock_hz, start)?))
}

/// Times a group through the TDM engine and returns each axis's edges, all starting on
/// the group's start tick (`now` + the engine's prefill and DIR setup time).
pub fn start_group(
    profiles: &[Profile],
    cfg: &TdmConfig,
    now: u64,
) -> Result<(u64, Vec<Box<dyn StepSource>>), CtlError> {
    let report = tdm_report(profiles, cfg)?;
    start_timed(profiles, &report, cfg, now)
}

/// [`start_group`] with the TDM run already done (it may run without the board locked).
pub fn start_timed(
    profiles: &[Profile],
    report: &tdm::Report,
    cfg: &TdmConfig,
    now: u64,
) -> Result<(u64, Vec<Box<dyn StepSource>>), CtlError> {
    if report.underruns > 0 {
        return Err(CtlError::Timing(format!(
            "the TDM calculator cannot keep up with this group: {} underruns, last edge {} ticks late",
            report.underruns, report.max_late_ticks
        )));
    }
    debug_assert_eq!(report.start_skew_ticks, 0);
    let start = now + report.start_tick;
    let sources = profiles
        .iter()
        .map(|p| start_move(p.clone(), cfg.clock_hz, start))
        .collect::<Result<Vec<_>, _>>()?;
    Ok((start, sources))
}

/// Runs the TDM engine over a group (edges discarded) and reports its timing.
pub fn tdm_report(profiles: &[Profile], cfg: &TdmConfig) -> Result<tdm::Report, CtlError> {
    let mut axes = profiles
        .iter()
        .map(|p| tdm::Axis::new(p.clone(), cfg.clock_hz))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| CtlError::Timing(e.to_string()))?;
    let board = tdm::Board::new(*cfg, &mut axes).map_err(|e| CtlError::Timing(e.to_string()))?;
    Ok(board.run(|_| {}))
}

/// A constant-deceleration stop from `speed` (steps/s) at `amax`: limits mode with the
/// start speed equal to the speed limit (DESIGN.md §2), so the core plans it. `None` when
/// the axis is slow enough to stop on the spot (less than half a step to go).
pub fn stop_profile(speed: f64, amax: f64) -> Option<Profile> {
    let dist = multistep_core::stop_distance(speed, amax, None);
    if speed.is_nan() || speed <= 0.0 || dist < 0.5 {
        return None;
    }
    let steps = dist.ceil() as u64;
    // Rounding the distance up needs a little cruise; the planner finds it.
    MoveSpec {
        steps: Some(steps),
        params: MoveParams {
            vmax: Some(speed),
            amax: Some(amax),
            start_speed: Some(speed),
            ..MoveParams::default()
        },
        ..MoveSpec::default()
    }
    .plan()
    .ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stop_profile_decelerates_from_the_current_speed() {
        for &(v, a) in &[(4000.0, 20000.0), (123.4, 1000.0), (50_000.0, 1e6)] {
            let p = stop_profile(v, a).expect("plannable");
            let want = (v * v / (2.0 * a)).ceil() as u64;
            assert_eq!(p.steps(), want);
            assert!((p.velocity(0.0) - v).abs() < 1e-6 * v);
            assert!(p.velocity(p.duration()).abs() < 1e-6 * v);
            let (vp, ap) = p.peaks();
            assert!(
                vp <= v * (1.0 + 1e-9) && ap <= a * (1.0 + 1e-9),
                "{vp} {ap}"
            );
        }
        assert!(stop_profile(10.0, 1e6).is_none());
    }

    #[test]
    fn tdm_group_edges_are_the_streamed_edges() {
        let spec = |n: u64, v: f64| MoveSpec {
            steps: Some(n),
            params: MoveParams {
                vmax: Some(v),
                amax: Some(4.0 * v),
                ..MoveParams::default()
            },
            ..Default::default()
        };
        let profiles: Vec<Profile> = [(3000, 4000.0), (10, 100.0), (777, 2500.0)]
            .iter()
            .map(|&(n, v)| spec(n, v).plan().unwrap())
            .collect();
        let cfg = TdmConfig {
            clock_hz: 1e7,
            fifo_depth: 4,
            ..TdmConfig::default()
        };
        let mut axes: Vec<tdm::Axis> = profiles
            .iter()
            .map(|p| tdm::Axis::new(p.clone(), 1e7).unwrap())
            .collect();
        let mut rises = vec![Vec::new(); 3];
        let report = tdm::Board::new(cfg, &mut axes)
            .unwrap()
            .run(|p| rises[p.axis].push(p.rise));
        assert_eq!(report.underruns, 0);
        let (start, mut sources) = start_group(&profiles, &cfg, 5000).unwrap();
        assert_eq!(start, 5000 + report.start_tick);
        for (m, src) in sources.iter_mut().enumerate() {
            let mut got = Vec::new();
            while let Some(t) = src.peek() {
                got.push(t - 5000);
                src.take();
            }
            assert_eq!(got, rises[m], "axis {m}");
        }
    }

    #[test]
    fn a_group_the_calculator_cannot_serve_is_refused() {
        // 16 axes at 200 000 steps/s with a 1 MHz clock: 5 ticks per period, 54 cycles each.
        let p = MoveSpec {
            steps: Some(2000),
            params: MoveParams {
                vmax: Some(2e5),
                amax: Some(1e9),
                ..MoveParams::default()
            },
            ..Default::default()
        }
        .plan()
        .unwrap();
        let cfg = TdmConfig {
            clock_hz: 1e6,
            fifo_depth: 4,
            ..TdmConfig::default()
        };
        assert!(matches!(
            start_group(&vec![p; 16], &cfg, 0),
            Err(CtlError::Timing(_))
        ));
    }

    #[test]
    fn edge_source_is_the_generator_shifted() {
        let p = MoveSpec {
            steps: Some(500),
            params: MoveParams {
                vmax: Some(1000.0),
                amax: Some(5000.0),
                ..MoveParams::default()
            },
            ..Default::default()
        }
        .plan()
        .unwrap();
        let direct: Vec<u64> = EdgeGenerator::new(p.clone(), 1e6).unwrap().collect();
        let mut s = EdgeSource::new(p, 1e6, 777).unwrap();
        assert_eq!(s.steps_left(), 500);
        let mut got = Vec::new();
        while let Some(t) = s.peek() {
            got.push(t - 777);
            s.take();
        }
        assert_eq!(got, direct);
        assert_eq!(s.end_tick(), 777 + direct.last().unwrap());
    }
}
