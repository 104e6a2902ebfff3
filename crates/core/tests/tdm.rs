//! The TDM engine against the plan's edges and against a tick-by-tick reference model.

use multistep_core::tdm::{
    k_max, min_period_ticks, rate_move, Axis, AxisStats, Board, Latencies, Policy, PulseShape,
    Report, StepPulse, TdmConfig, TdmError,
};
use multistep_core::{
    EdgeGenerator, Family, MoveParams, MoveSpec, PhaseMove, Profile, Segment, StepDirTiming,
};
use proptest::prelude::*;
use std::collections::VecDeque;

const F: f64 = 50e6;

fn seed000_axes() -> Vec<Axis> {
    [2400u64, 1800]
        .iter()
        .map(|&n| {
            let spec = MoveSpec {
                steps: Some(n),
                params: MoveParams {
                    accel_time: Some(0.02),
                    cruise_time: Some(0.01),
                    decel_time: Some(0.02),
                    ..MoveParams::default()
                },
                ..MoveSpec::default()
            };
            Axis::new(spec.plan().unwrap(), F).unwrap()
        })
        .collect()
}

/// Runs a board and keeps every pulse per axis.
fn run(cfg: TdmConfig, axes: &mut [Axis]) -> (Report, Vec<Vec<StepPulse>>) {
    let mut pulses = vec![Vec::new(); axes.len()];
    let r = Board::new(cfg, axes)
        .unwrap()
        .run(|p| pulses[p.axis].push(p));
    (r, pulses)
}

fn plan_edges(p: &Profile, clock: f64) -> Vec<u64> {
    EdgeGenerator::new(p.clone(), clock).unwrap().collect()
}

/// Every axis: rises are the plan's edges shifted by the start tick plus a lateness that
/// only grows, by exactly the reported delays; no lateness without a reported underrun.
fn check_against_plan(r: &Report, axes: &[Axis], pulses: &[Vec<StepPulse>], clock: f64) {
    for (m, a) in axes.iter().enumerate() {
        let plan = plan_edges(a.profile().unwrap(), clock);
        let got = &pulses[m];
        assert_eq!(got.len(), plan.len(), "axis {m}: every step emitted once");
        let (mut late, mut jumps) = (0u64, 0u64);
        for (j, (p, e)) in got.iter().zip(&plan).enumerate() {
            assert_eq!(p.step, j as u64 + 1);
            let off = p.rise - r.start_tick - e;
            assert!(
                off >= late,
                "axis {m} step {}: an edge moved earlier",
                j + 1
            );
            if off > late {
                jumps += 1;
                late = off;
            }
            assert!(p.fall > p.rise);
        }
        let s = a.stats();
        assert_eq!(
            late, s.late_ticks,
            "axis {m}: the delay is the reported one"
        );
        assert_eq!(jumps, s.underruns, "axis {m}: one delay per underrun");
        assert_eq!(s.steps, plan.len() as u64);
        assert_eq!(s.start_tick, r.start_tick);
        assert_eq!(s.min_slack_ticks < 0, s.underruns > 0);
    }
    assert_eq!(r.start_skew_ticks, 0);
}

#[test]
fn seed000_two_axis_run_passes_with_fifo_depth_1() {
    for policy in [Policy::RoundRobin, Policy::EarliestDeadline] {
        let mut axes = seed000_axes();
        let cfg = TdmConfig {
            policy,
            ..TdmConfig::default()
        };
        let (r, pulses) = run(cfg, &mut axes);
        assert_eq!(r.underruns, 0, "{policy:?}");
        assert!(r.min_slack_ticks > 0);
        assert_eq!(r.edges, 4200);
        assert_eq!(r.start_skew_ticks, 0);
        // prefill: one period per axis, 51 cycles each
        assert_eq!(r.start_tick, 2 * 51);
        // both moves end at 50 ms: round(f·T) = 2.5 M ticks after the common start
        assert_eq!(pulses[0].last().unwrap().rise, r.start_tick + 2_500_000);
        assert_eq!(pulses[1].last().unwrap().rise, r.start_tick + 2_500_000);
        check_against_plan(&r, &axes, &pulses, F);
        let u = r.calculator_utilization();
        assert!(u > 0.0 && u < 0.2, "{u}");
        assert_eq!(r.busy_cycles, 4200 * 51);
    }
}

#[test]
fn overloaded_board_reports_underruns_and_the_exact_delay() {
    // 32 axes at 100 k steps/s: 500-tick periods, 51 cycles each: about 3× overload
    let p = rate_move(100e3, 0.02, 0.01, 0.02).unwrap();
    let mut axes: Vec<Axis> = (0..32).map(|_| Axis::new(p.clone(), F).unwrap()).collect();
    for policy in [Policy::RoundRobin, Policy::EarliestDeadline] {
        let cfg = TdmConfig {
            policy,
            fifo_depth: 4,
            ..TdmConfig::default()
        };
        let (r, pulses) = run(cfg, &mut axes);
        assert!(r.underruns > 0, "{policy:?}");
        assert!(r.min_slack_ticks < 0);
        assert!(r.max_late_ticks > 0);
        check_against_plan(&r, &axes, &pulses, F);
    }
}

#[test]
fn start_waits_for_prefill_and_dir_setup() {
    let mut axes = seed000_axes();
    let cfg = TdmConfig {
        fifo_depth: 3,
        step_dir: StepDirTiming {
            dir_setup_ticks: 10_000,
            ..StepDirTiming::default()
        },
        ..TdmConfig::default()
    };
    let (r, pulses) = run(cfg, &mut axes);
    assert_eq!(r.start_tick, 10_000);
    check_against_plan(&r, &axes, &pulses, F);
    let cfg = TdmConfig {
        fifo_depth: 3,
        step_dir: StepDirTiming {
            dir_setup_ticks: 5,
            ..StepDirTiming::default()
        },
        ..TdmConfig::default()
    };
    let (r, _) = run(cfg, &mut axes);
    assert_eq!(r.start_tick, 6 * 51, "3 periods for each of 2 axes");
    let cfg = TdmConfig {
        fifo_depth: 3,
        latencies: Latencies::RADIX4_PIPELINED,
        ..TdmConfig::default()
    };
    let (r, pulses) = run(cfg, &mut axes);
    assert_eq!(
        r.start_tick,
        5 * 32 + 51,
        "6 periods started 32 cycles apart"
    );
    check_against_plan(&r, &axes, &pulses, F);
}

#[test]
fn fixed_pulse_width() {
    let mut axes = seed000_axes();
    let cfg = TdmConfig {
        step_dir: StepDirTiming {
            pulse: PulseShape::Fixed { ticks: 100 },
            ..StepDirTiming::default()
        },
        ..TdmConfig::default()
    };
    let (r, pulses) = run(cfg, &mut axes);
    assert!(pulses.iter().flatten().all(|p| p.fall == p.rise + 100));
    assert_eq!(r.merged_pulses, 0);
}

#[test]
fn bad_configurations_are_typed_errors() {
    let mut axes = seed000_axes();
    let err = |cfg: TdmConfig, axes: &mut [Axis]| Board::new(cfg, axes).err();
    assert_eq!(err(TdmConfig::default(), &mut []), Some(TdmError::NoAxes));
    let d0 = TdmConfig {
        fifo_depth: 0,
        ..TdmConfig::default()
    };
    assert!(matches!(
        err(d0, &mut axes),
        Some(TdmError::FifoDepth { .. })
    ));
    let zero = TdmConfig {
        latencies: Latencies {
            mul: 0,
            div: 0,
            sqrt: 0,
            overhead: 0,
            pipelined: true,
        },
        ..TdmConfig::default()
    };
    assert_eq!(err(zero, &mut axes), Some(TdmError::ZeroCycles));
    let clk = TdmConfig {
        clock_hz: 1e6,
        ..TdmConfig::default()
    };
    assert!(matches!(
        err(clk, &mut axes),
        Some(TdmError::ClockMismatch { axis: 0, .. })
    ));
    let w0 = TdmConfig {
        step_dir: StepDirTiming {
            pulse: PulseShape::Fixed { ticks: 0 },
            ..StepDirTiming::default()
        },
        ..TdmConfig::default()
    };
    assert_eq!(err(w0, &mut axes), Some(TdmError::ZeroPulseWidth));
    let mut many: Vec<Axis> = (0..65).map(|_| axes[0].clone()).collect();
    assert!(matches!(
        err(TdmConfig::default(), &mut many),
        Some(TdmError::TooManyAxes { .. })
    ));
}

#[test]
fn k_max_at_100k_steps_per_s_against_eq12() {
    let p = rate_move(100e3, 0.02, 0.01, 0.02).unwrap();
    let mut storage: Vec<Axis> = (0..24).map(|_| Axis::new(p.clone(), F).unwrap()).collect();
    let mut k = |latencies, fifo_depth| {
        let cfg = TdmConfig {
            latencies,
            fifo_depth,
            ..TdmConfig::default()
        };
        let km = k_max(&cfg, std::slice::from_ref(&p), &mut storage).unwrap();
        assert_eq!(km.min_period_ticks, 500);
        assert!(!km.capped);
        assert!(km.first_failure.unwrap().underruns > 0);
        (km.k_max as u64, km.k_eq12)
    };
    // one period at a time, identical moves started together: every common edge needs k
    // periods within the shortest period, which is eq. (12): ⌊500/51⌋ = 9. With one FIFO
    // slot they are computed after the rise that empties it, and the scheduler sees that
    // room a tick later: k·51 ≤ 500 − 1, still 9 (at 50 cycles a period it was one short)
    assert_eq!(k(Latencies::RADIX4, 1), (9, 9));
    // a second slot: eq. (12) exactly
    assert_eq!(k(Latencies::RADIX4, 4), (9, 9));
    // pipelined: t_calc = 32 but each period takes 51 cycles to arrive. With depth 1 the
    // k-th period of a common edge is ready (k−1)·32 + 51 + 1 after it: k ≤ (500−52)/32 + 1
    assert_eq!(k(Latencies::RADIX4_PIPELINED, 1), (15, 15));
    // a second FIFO slot hides the latency: eq. (12) again
    assert_eq!(k(Latencies::RADIX4_PIPELINED, 2), (15, 15));
}

fn arb_profile(max_steps: u64, max_time: f64) -> impl Strategy<Value = Profile> {
    let phase = (
        1..=max_steps,
        0.0..1.0f64,
        0.0..1.0f64,
        0.0..1.0f64,
        0usize..6,
    )
        .prop_filter_map("feasible phase move", move |(steps, a, b, c, fam)| {
            let family = Family::parse(Family::NAMES[fam], None, None, None).ok()?;
            Profile::phase(&PhaseMove {
                steps,
                accel_time: 0.05 * max_time + a * max_time,
                cruise_time: b * max_time,
                decel_time: 0.05 * max_time + c * max_time,
                start_speed: 0.0,
                end_speed: 0.0,
                family,
            })
            .ok()
        });
    let segs = (1..=max_steps, 0.1..1.0f64, 0.0..1.0f64).prop_filter_map(
        "feasible segments",
        move |(n, t, v)| {
            // accelerate from v0 over t, then brake to rest: v0·t ≤ n keeps both ends ≥ 0
            let t = t * max_time * 0.5;
            let v0 = v * n as f64 / t;
            let v1 = 2.0 * n as f64 / t - v0;
            let segs = [
                Segment {
                    v0,
                    duration: t,
                    steps: n,
                },
                Segment {
                    v0: v1,
                    duration: 2.0 * n as f64 / v1.max(1e-9),
                    steps: n,
                },
            ];
            Profile::segments(&segs).ok()
        },
    );
    prop_oneof![3 => phase, 1 => segs]
}

fn arb_policy() -> impl Strategy<Value = Policy> {
    prop_oneof![Just(Policy::RoundRobin), Just(Policy::EarliestDeadline)]
}

/// A board small enough for the tick-by-tick model: up to 6 short moves at a 1 MHz clock,
/// any depth to 4, policy and calculator timing (overloaded or not), DIR setup to 500.
fn arb_small_board() -> impl Strategy<Value = (Vec<Profile>, TdmConfig)> {
    (
        prop::collection::vec(arb_profile(120, 0.02), 1..=6),
        1usize..=4,
        arb_policy(),
        1u32..60,
        prop::array::uniform3(0u32..30),
        any::<bool>(),
        0u64..500,
    )
        .prop_map(
            |(profiles, depth, policy, cycles, units, pipelined, dir_setup)| {
                let cfg = TdmConfig {
                    clock_hz: 1e6,
                    fifo_depth: depth,
                    policy,
                    latencies: Latencies {
                        mul: units[0],
                        div: cycles,
                        sqrt: units[1],
                        overhead: units[2],
                        pipelined,
                    },
                    step_dir: StepDirTiming {
                        dir_setup_ticks: dir_setup,
                        ..StepDirTiming::default()
                    },
                };
                (profiles, cfg)
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    /// Random moves, k up to 32, random depth and policy, a calculator fast enough that
    /// (k+1)·t_calc ≤ Δt_min: a freed FIFO slot is refilled within k+1 computations (the
    /// one running and one per other axis), before the shortest period ends, so there is
    /// no underrun and every axis emits exactly the plan's edges after the common start.
    #[test]
    fn parity_with_plan_for_random_boards(
        profiles in prop::collection::vec(arb_profile(3000, 0.3), 1..=32),
        depth in 1usize..=8,
        policy in arb_policy(),
        frac in 0.05..1.0f64,
    ) {
        let k = profiles.len() as u64;
        let dmin = profiles.iter().map(|p| min_period_ticks(p, F).unwrap()).min().unwrap();
        let c = (frac * (dmin / (k + 1)) as f64) as u32;
        prop_assume!(c >= 1);
        let cfg = TdmConfig {
            fifo_depth: depth,
            policy,
            latencies: Latencies { mul: 0, div: c, sqrt: 0, overhead: 0, pipelined: false },
            ..TdmConfig::default()
        };
        let mut axes: Vec<Axis> = profiles.iter().map(|p| Axis::new(p.clone(), F).unwrap()).collect();
        let (r, pulses) = run(cfg, &mut axes);
        prop_assert_eq!(r.underruns, 0);
        prop_assert!(r.min_slack_ticks >= 0);
        prop_assert_eq!(r.start_skew_ticks, 0);
        for (a, got) in axes.iter().zip(&pulses) {
            let plan = plan_edges(a.profile().unwrap(), F);
            prop_assert_eq!(got.len(), plan.len());
            prop_assert!(got.iter().zip(&plan).all(|(p, e)| p.rise == r.start_tick + e));
        }
    }

    /// Overloaded or not: every delay is reported as an underrun with its exact size, and
    /// no edge moves otherwise.
    #[test]
    fn every_delay_is_a_reported_underrun(
        profiles in prop::collection::vec(arb_profile(2000, 0.05), 1..=32),
        depth in 1usize..=8,
        policy in arb_policy(),
        div in 1u32..400,
    ) {
        let cfg = TdmConfig {
            fifo_depth: depth,
            policy,
            latencies: Latencies { div, ..Latencies::default() },
            ..TdmConfig::default()
        };
        let mut axes: Vec<Axis> = profiles.iter().map(|p| Axis::new(p.clone(), F).unwrap()).collect();
        let (r, pulses) = run(cfg, &mut axes);
        check_against_plan(&r, &axes, &pulses, F);
    }

    /// The event-driven engine against a tick-by-tick model on small boards, overloaded or not.
    #[test]
    fn engine_matches_tick_by_tick_reference((profiles, cfg) in arb_small_board()) {
        let mut axes: Vec<Axis> = profiles.iter().map(|p| Axis::new(p.clone(), cfg.clock_hz).unwrap()).collect();
        let (r, pulses) = run(cfg, &mut axes);
        let (start, rises, under) = reference(&cfg, &profiles);
        prop_assert_eq!(r.start_tick, start);
        for m in 0..axes.len() {
            let got: Vec<u64> = pulses[m].iter().map(|p| p.rise).collect();
            prop_assert_eq!(&got, &rises[m], "axis {}", m);
            prop_assert_eq!(axes[m].stats().underruns, under[m], "axis {}", m);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// The whole output against the tick-by-tick model on small boards, overloaded or
    /// not: every pulse, rise and fall, in the order the sink gets it, each axis's stats
    /// and the report, with either pulse shape.
    #[test]
    fn engine_output_matches_tick_by_tick_reference(
        (profiles, mut cfg) in arb_small_board(),
        width in prop::option::of(1u64..40),
    ) {
        cfg.step_dir.pulse = width.map_or(PulseShape::HalfInterval, |ticks| PulseShape::Fixed { ticks });
        let mut axes: Vec<Axis> = profiles.iter().map(|p| Axis::new(p.clone(), cfg.clock_hz).unwrap()).collect();
        let mut got = Vec::new();
        let r = Board::new(cfg, &mut axes).unwrap().run(|p| got.push(p));
        let run = reference_run(&cfg, &profiles);
        let (want, stats) = reference_pulses(&cfg, &run);
        prop_assert_eq!(&got, &want);
        for (m, a) in axes.iter().enumerate() {
            prop_assert_eq!(a.stats(), &stats[m], "axis {}", m);
        }
        prop_assert_eq!(r.start_tick, run.start);
        prop_assert_eq!(r.edges, want.len() as u64);
        prop_assert_eq!(r.end_tick, stats.iter().map(|s| s.last_rise).max().unwrap());
        prop_assert_eq!(r.underruns, stats.iter().map(|s| s.underruns).sum::<u64>());
        prop_assert_eq!(r.max_late_ticks, stats.iter().map(|s| s.late_ticks).max().unwrap());
        prop_assert_eq!(r.min_slack_ticks, stats.iter().map(|s| s.min_slack_ticks).min().unwrap());
        prop_assert_eq!(r.merged_pulses, stats.iter().map(|s| s.merged_pulses).sum::<u64>());
    }
}

// ---------------------------------------------------------------------------------------
// A tick-by-tick reference model: FIFOs hold real periods with the tick each becomes
// ready, pulse units act on every tick, nothing is known ahead of time. Slow, so only for
// short moves at a slow clock.

#[derive(Clone, Copy, PartialEq)]
enum Unit {
    NotStarted,
    Counting { rise: u64 },
    Waiting { since: u64 },
    Done,
}

struct RefAxis {
    periods: VecDeque<u64>,
    /// Computed or being computed: (period, ready tick), in step order.
    fifo: VecDeque<(u64, u64)>,
    unit: Unit,
    loaded: usize,
    total: usize,
    rises: Vec<u64>,
    underruns: u64,
    /// Tick each period was loaded, and the tick it was ready, in step order.
    loads: Vec<u64>,
    readies: Vec<u64>,
}

impl RefAxis {
    /// The pulse unit needs a period at tick t.
    fn try_load(&mut self, t: u64) {
        loop {
            if self.loaded == self.total {
                self.unit = Unit::Done;
                return;
            }
            match self.fifo.front() {
                Some(&(p, ready)) if ready <= t => {
                    self.fifo.pop_front();
                    self.loaded += 1;
                    self.loads.push(t);
                    self.readies.push(ready);
                    self.unit = Unit::Counting { rise: t + p };
                    if p > 0 {
                        return;
                    }
                    self.rises.push(t);
                }
                _ => {
                    if !matches!(self.unit, Unit::Waiting { .. }) {
                        self.underruns += 1;
                        self.unit = Unit::Waiting { since: t };
                    }
                    return;
                }
            }
        }
    }

    /// Tick the FIFO runs dry: when the pulse unit needs the period after all it holds.
    fn deadline(&self, start: u64) -> u64 {
        let mut need = match self.unit {
            Unit::NotStarted => start,
            Unit::Counting { rise } => rise,
            Unit::Waiting { since } => since,
            Unit::Done => u64::MAX,
        };
        for &(p, ready) in &self.fifo {
            need = need.max(ready) + p;
        }
        need
    }
}

/// Start tick, every axis's rises and underrun count.
fn reference(cfg: &TdmConfig, profiles: &[Profile]) -> (u64, Vec<Vec<u64>>, Vec<u64>) {
    let run = reference_run(cfg, profiles);
    let under = run.axes.iter().map(|a| a.underruns).collect();
    (
        run.start,
        run.axes.into_iter().map(|a| a.rises).collect(),
        under,
    )
}

/// A finished reference run: the start tick, the axes, and the axis of every period
/// computed in the calculator's order.
struct RefRun {
    start: u64,
    axes: Vec<RefAxis>,
    order: Vec<usize>,
}

fn reference_run(cfg: &TdmConfig, profiles: &[Profile]) -> RefRun {
    let (ii, lat) = (cfg.latencies.interval(), cfg.latencies.latency());
    let d = cfg.fifo_depth;
    let mut axes: Vec<RefAxis> = profiles
        .iter()
        .map(|p| {
            let edges = plan_edges(p, cfg.clock_hz);
            let periods: VecDeque<u64> = edges
                .iter()
                .scan(0, |last, &e| {
                    let q = e - *last;
                    *last = e;
                    Some(q)
                })
                .collect();
            RefAxis {
                total: periods.len(),
                periods,
                fifo: VecDeque::new(),
                unit: Unit::NotStarted,
                loaded: 0,
                rises: Vec::new(),
                underruns: 0,
                loads: Vec::new(),
                readies: Vec::new(),
            }
        })
        .collect();
    let k = axes.len();
    let prefill: u64 = axes.iter().map(|a| a.total.min(d) as u64).sum();
    let start = cfg.step_dir.dir_setup_ticks.max((prefill - 1) * ii + lat);
    let mut next_issue = 0u64;
    let mut ptr = 0;
    let mut t = 0u64;
    let mut order = Vec::new();
    while !axes.iter().all(|a| a.unit == Unit::Done) {
        // the scheduler sees each FIFO as it was before this tick's pops (the core's
        // scheduler does not look at pops)
        let held: Vec<usize> = axes.iter().map(|a| a.fifo.len()).collect();
        for a in axes.iter_mut() {
            match a.unit {
                Unit::NotStarted if t == start => a.try_load(t),
                Unit::Counting { rise } if rise == t => {
                    a.rises.push(t);
                    a.try_load(t);
                }
                Unit::Waiting { .. } => a.try_load(t),
                _ => {}
            }
        }
        if t >= next_issue {
            let eligible = |m: usize| !axes[m].periods.is_empty() && held[m] < d;
            let pick = match cfg.policy {
                Policy::RoundRobin => (0..k).map(|i| (ptr + i) % k).find(|&m| eligible(m)),
                Policy::EarliestDeadline => (0..k)
                    .filter(|&m| eligible(m))
                    .min_by_key(|&m| (axes[m].deadline(start), m)),
            };
            if let Some(m) = pick {
                ptr = (m + 1) % k;
                order.push(m);
                let p = axes[m].periods.pop_front().unwrap();
                axes[m].fifo.push_back((p, t + lat));
                next_issue = t + ii;
            }
        }
        t += 1;
        assert!(t < 1 << 32, "reference model did not finish");
    }
    RefRun { start, axes, order }
}

/// What the engine must hand its sink for a reference run, in order, and each axis's
/// stats: pulse j closes when period j + 1 is computed, the last one with it (module
/// text of `tdm::board` and `tdm::pulse`).
fn reference_pulses(cfg: &TdmConfig, run: &RefRun) -> (Vec<StepPulse>, Vec<AxisStats>) {
    let fall = |a: &RefAxis, j: usize| -> u64 {
        let rise = a.rises[j];
        match cfg.step_dir.pulse {
            PulseShape::Fixed { ticks } => rise + ticks,
            // half of the next period after its load; the last pulse half of its own
            PulseShape::HalfInterval => match a.rises.get(j + 1) {
                Some(&next) => {
                    let load = a.loads[j + 1];
                    load + ((next - load) / 2).max(1)
                }
                None => rise + ((rise - a.loads[j]) / 2).max(1),
            },
        }
    };
    let pulse = |m: usize, j: usize| StepPulse {
        axis: m,
        step: j as u64 + 1,
        rise: run.axes[m].rises[j],
        fall: fall(&run.axes[m], j),
    };
    let mut computed = vec![0usize; run.axes.len()];
    let mut out = Vec::new();
    for &m in &run.order {
        computed[m] += 1;
        let j = computed[m];
        if j >= 2 {
            out.push(pulse(m, j - 2));
        }
        if j == run.axes[m].total {
            out.push(pulse(m, j - 1));
        }
    }
    let stats = run
        .axes
        .iter()
        .map(|a| {
            // period j is needed at the previous rise (period 1 at the start)
            let due = |j: usize| if j == 0 { run.start } else { a.rises[j - 1] };
            let late = |j: usize| a.readies[j].saturating_sub(due(j));
            let n = a.total;
            AxisStats {
                steps: n as u64,
                underruns: (0..n).filter(|&j| late(j) > 0).count() as u64,
                late_ticks: (0..n).map(late).sum(),
                min_slack_ticks: (1..n)
                    .map(|j| due(j) as i64 - a.readies[j] as i64)
                    .min()
                    .unwrap_or(i64::MAX),
                start_tick: a.loads[0],
                last_rise: a.rises[n - 1],
                merged_pulses: (0..n.saturating_sub(1))
                    .filter(|&j| fall(a, j) >= a.rises[j + 1])
                    .count() as u64,
            }
        })
        .collect();
    (out, stats)
}

#[test]
fn a_run_that_could_pass_tick_2_pow_57_is_refused() {
    // 2^40 steps of ~2^17-cycle periods: more calculator work than the tick range holds
    let p = MoveSpec {
        steps: Some(1 << 40),
        params: MoveParams {
            vmax: Some(1e9),
            amax: Some(1e12),
            ..MoveParams::default()
        },
        ..MoveSpec::default()
    }
    .plan()
    .unwrap();
    let mut axes = vec![Axis::new(p, F).unwrap()];
    let slow = TdmConfig {
        latencies: Latencies {
            div: 1 << 17,
            ..Latencies::default()
        },
        ..TdmConfig::default()
    };
    assert_eq!(Board::new(slow, &mut axes).err(), Some(TdmError::TooLong));
    assert!(Board::new(TdmConfig::default(), &mut axes).is_ok());
}
