//! A move's plan as plottable series: position and velocity from the core's profile, and
//! the step rate counted from the exact edge generator's own edges — what the board would
//! actually emit. The page draws these; it never re-derives a profile.

use multistep_controller::board::PlannedAxis;
use multistep_core::{EdgeGenerator, PlanError};
use serde::Serialize;

/// Samples per series.
pub const SAMPLES: usize = 200;
/// Above this many steps the edge-counted rate is left out (it costs one pass over edges).
pub const MAX_COUNTED_EDGES: u64 = 5_000_000;

#[derive(Debug, Serialize)]
pub struct AxisPreview {
    pub axis: String,
    /// Counted position before and after the move.
    pub start: i64,
    pub target: i64,
    pub steps: u64,
    /// Seconds; 0 when the axis would not move.
    pub duration: f64,
    pub peak_speed: f64,
    pub peak_accel: f64,
    /// Tick (board clock) of the last step edge.
    pub last_edge_tick: u64,
    /// Sample times (s), absolute position (steps) and signed velocity (steps/s).
    pub t: Vec<f64>,
    pub position: Vec<f64>,
    pub velocity: Vec<f64>,
    /// Signed steps per second in equal windows of the move, counted from the edges.
    pub edge_rate: Option<Vec<f64>>,
}

pub fn axis_preview(p: &PlannedAxis, clock_hz: f64) -> Result<AxisPreview, PlanError> {
    let start = p.target - p.delta;
    let sign = p.delta.signum() as f64;
    let Some(profile) = &p.profile else {
        return Ok(AxisPreview {
            axis: p.axis.clone(),
            start,
            target: p.target,
            steps: 0,
            duration: 0.0,
            peak_speed: 0.0,
            peak_accel: 0.0,
            last_edge_tick: 0,
            t: vec![0.0],
            position: vec![start as f64],
            velocity: vec![0.0],
            edge_rate: None,
        });
    };
    let d = profile.duration();
    let t: Vec<f64> = (0..=SAMPLES)
        .map(|k| d * k as f64 / SAMPLES as f64)
        .collect();
    let position = t
        .iter()
        .map(|&x| start as f64 + sign * profile.position(x))
        .collect();
    let velocity = t.iter().map(|&x| sign * profile.velocity(x)).collect();
    let gen = EdgeGenerator::new(profile.clone(), clock_hz)?;
    let last_edge_tick = gen.last_edge_tick();
    let edge_rate = (profile.steps() <= MAX_COUNTED_EDGES && d > 0.0).then(|| {
        // About 8 steps per window at least, so a short move's rate is not all 0 or 1 step.
        let bins = (profile.steps() / 8).clamp(1, SAMPLES as u64) as usize;
        let mut counts = vec![0u64; bins];
        let window = d / bins as f64;
        for e in gen {
            let k = ((e as f64 / clock_hz) / window) as usize;
            counts[k.min(bins - 1)] += 1;
        }
        counts.iter().map(|&c| sign * c as f64 / window).collect()
    });
    let (peak_speed, peak_accel) = profile.peaks();
    Ok(AxisPreview {
        axis: p.axis.clone(),
        start,
        target: p.target,
        steps: profile.steps(),
        duration: d,
        peak_speed,
        peak_accel,
        last_edge_tick,
        t,
        position,
        velocity,
        edge_rate,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use multistep_core::{MoveParams, MoveSpec};

    #[test]
    fn series_follow_the_profile_and_the_edges_add_up() {
        let profile = MoveSpec {
            steps: Some(3000),
            params: MoveParams {
                vmax: Some(4000.0),
                amax: Some(20000.0),
                ..MoveParams::default()
            },
            ..Default::default()
        }
        .plan()
        .unwrap();
        let planned = PlannedAxis {
            axis: "X".into(),
            delta: -3000,
            target: 500,
            profile: Some(profile.clone()),
        };
        let a = axis_preview(&planned, 1e6).unwrap();
        assert_eq!((a.start, a.target, a.steps), (3500, 500, 3000));
        assert_eq!(a.t.len(), SAMPLES + 1);
        assert_eq!(a.position[0], 3500.0);
        assert!((a.position[SAMPLES] - 500.0).abs() < 1e-6);
        assert!(a
            .velocity
            .iter()
            .all(|&v| (-4000.0 * (1.0 + 1e-9)..=0.0).contains(&v)));
        let rate = a.edge_rate.unwrap();
        assert_eq!(rate.len(), SAMPLES);
        let window = a.duration / SAMPLES as f64;
        let total: f64 = rate.iter().map(|r| -r * window).sum();
        assert!((total - 3000.0).abs() < 1e-6, "{total}");
        assert_eq!(a.last_edge_tick, (a.duration * 1e6).round() as u64);
    }

    #[test]
    fn an_axis_that_stays_put_has_a_flat_preview() {
        let planned = PlannedAxis {
            axis: "Y".into(),
            delta: 0,
            target: 7,
            profile: None,
        };
        let a = axis_preview(&planned, 1e6).unwrap();
        assert_eq!(
            (a.start, a.target, a.steps, a.position.clone()),
            (7, 7, 0, vec![7.0])
        );
    }
}
