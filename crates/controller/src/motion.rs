//! Where an axis's step edges come from. The board only sees [`StepSource`]: a stream of
//! absolute edge ticks plus the commanded speed, so the exact edge generator used here
//! and a TDM engine are interchangeable without touching the board.

use multistep_core::{EdgeGenerator, MoveSpec, PlanError, Profile};

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

/// Makes the step source of a planned move; the one place to swap in another engine.
pub fn start_move(
    profile: Profile,
    clock_hz: f64,
    start: u64,
) -> Result<Box<dyn StepSource>, PlanError> {
    Ok(Box::new(EdgeSource::new(profile, clock_hz, start)?))
}

/// A constant-deceleration stop from `speed` (steps/s) at `amax`: limits mode with the
/// start speed equal to the speed limit (DESIGN.md §2), so the core plans it. `None` when
/// the axis is slow enough to stop on the spot (less than half a step to go).
pub fn stop_profile(speed: f64, amax: f64) -> Option<Profile> {
    let dist = speed * speed / (2.0 * amax);
    if !(speed > 0.0) || dist < 0.5 {
        return None;
    }
    let steps = dist.ceil() as u64;
    // Rounding the distance up needs a little cruise; the planner finds it.
    MoveSpec {
        steps: Some(steps),
        vmax: Some(speed),
        amax: Some(amax),
        start_speed: Some(speed),
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
    fn edge_source_is_the_generator_shifted() {
        let p = MoveSpec {
            steps: Some(500),
            vmax: Some(1000.0),
            amax: Some(5000.0),
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
