//! Fixed-step RK4 driven by the exact edge stream. θ* changes only at edge ticks, so a step
//! that contains edges is split at each edge time: every RK4 sub-step sees a constant command
//! and the result is exact to RK4 order however many microsteps fall in one dt.

use crate::driver::SineTable;
use crate::error::SimError;
use crate::measures::{EnergyBalance, Measures};
use crate::model::{
    sin_cos_shifted, Command, Plant, State, COULOMB_SMOOTHING, E_CU, E_IN, E_MECH, IA, IB, NSTATE,
    OM, TH, ZA, ZB,
};
use crate::motor::Motor;
use crate::{DriverMode, SimConfig, SimResult, TraceRow};
use indicatif::ProgressBar;
use multistep_core::Num;

/// RK4's stability boundary is about 2.79 on the negative real axis and 2.83 on the imaginary
/// axis; we keep a margin.
pub const STABILITY_LIMIT: f64 = 2.5;

/// RK4's stability boundary on the imaginary axis, 2√2 (Hairer & Wanner, *Solving Ordinary
/// Differential Equations II*, §IV.2): an electrical angle that turns faster than this per
/// step is not followed, only amplified.
const RK4_IMAGINARY_BOUND: f64 = 2.0 * std::f64::consts::SQRT_2;

/// Shortest RK4 step (s). Shorter steps only add work: the fastest mode of the shipped
/// motors needs about 10 µs.
pub const MIN_DT: f64 = 1e-9;

/// The most RK4 steps one simulation may take: about a minute at ~0.1 µs per step (grid
/// steps plus one per edge). 500 s simulated at the default dt of 1 µs.
pub const MAX_RK4_STEPS: f64 = 5e8;

/// Runs expected to take longer than this many RK4 steps (a few seconds) show progress.
const PROGRESS_STEPS: f64 = 3e7;

/// The fastest rate of the linearised system, with its name, for the stability check.
pub fn fastest_mode(m: &Motor, cfg: &SimConfig) -> (&'static str, f64) {
    let d = &cfg.driver;
    let j = m.inertia();
    let mut modes = vec![
        (
            "rotor oscillation ω_n = √(N_r·K_m·I/J)",
            m.natural_frequency(d.current),
        ),
        (
            "mechanical damping (B + D_s)/J",
            (m.viscous_friction + m.iron_loss_eddy + m.oscillation_damping(d.current)) / j,
        ),
        (
            "smoothed dry friction T_c/(ω_s·J)",
            (m.coulomb_friction + m.iron_loss_hysteresis) / (COULOMB_SMOOTHING * j),
        ),
    ];
    if d.mode == DriverMode::Rl {
        modes.push((
            "PI current loop ω_c + R/L",
            std::f64::consts::TAU * d.bandwidth_hz + m.resistance / m.inductance,
        ));
    }
    if let Some(w) = cfg.peak_speed_hint {
        modes.push((
            "electrical frequency N_r·ω at peak speed",
            m.rotor_teeth as f64 * w.abs(),
        ));
    }
    modes
        .into_iter()
        .fold(("", 0.0), |a, b| if b.1 > a.1 { b } else { a })
}

/// Refuses a dt below [`MIN_DT`] or outside RK4's stability region for this motor and
/// driver.
pub fn check_step(m: &Motor, cfg: &SimConfig) -> Result<(), SimError> {
    let dt = cfg.dt;
    if !(dt.is_finite() && dt >= MIN_DT) {
        return Err(SimError::BadSetting {
            field: "dt",
            value: dt,
            why: format!(
                "must be at least {MIN_DT:e} s (and small enough to be stable for the motor)"
            ),
        });
    }
    let (mode, rate) = fastest_mode(m, cfg);
    if dt * rate > STABILITY_LIMIT {
        return Err(SimError::UnstableStep {
            dt,
            mode,
            rate,
            limit: STABILITY_LIMIT,
            max_dt: STABILITY_LIMIT / rate,
        });
    }
    Ok(())
}

#[inline(always)]
fn rk4<const IDEAL: bool>(p: &Plant, x: &mut State, u: &Command, h: f64) {
    let add = |x: &State, k: &State, s: f64| {
        let mut y = *x;
        for i in 0..NSTATE {
            y[i] += s * k[i];
        }
        y
    };
    // One sin_cos per step: the stages' angles are shifted from θ by at most h·|ω|.
    let phi = p.nr * x[TH];
    let (s, c) = phi.sin_cos();
    let stage = |k: &State, a: f64| {
        let y = add(x, k, a);
        let (sy, cy) = sin_cos_shifted(s, c, phi, p.nr * a * k[TH]);
        p.rhs_at::<IDEAL>(&y, u, sy, cy)
    };
    let k1 = p.rhs_at::<IDEAL>(x, u, s, c);
    let k2 = stage(&k1, 0.5 * h);
    let k3 = stage(&k2, 0.5 * h);
    let k4 = stage(&k3, h);
    for i in 0..NSTATE {
        x[i] += h / 6.0 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]);
    }
}

/// Checks the motor, driver, clock and dt: what every run needs.
fn check_inputs(m: &Motor, cfg: &SimConfig, clock_hz: f64) -> Result<(), SimError> {
    cfg.driver.validate()?;
    m.validate()?;
    if !(clock_hz.is_finite() && clock_hz > 0.0) {
        return Err(SimError::BadSetting {
            field: "clock",
            value: clock_hz,
            why: "must be > 0".into(),
        });
    }
    check_step(m, cfg)
}

/// Longest settling after the last edge (s): `cfg.settle_max`, or 8/(ζ·ω_n) within 5 ms…0.5 s.
pub fn settle_max(m: &Motor, cfg: &SimConfig) -> f64 {
    let wn = m.natural_frequency(cfg.driver.current);
    let zeta = m.effective_damping_ratio(cfg.driver.current);
    cfg.settle_max
        .unwrap_or_else(|| (8.0 / (zeta.max(1e-3) * wn)).clamp(5e-3, 0.5))
}

/// The RK4 steps a move of `duration_s` and `edges` edges takes at most: the grid up to the
/// longest settling, plus a split step per edge. Refuses more than [`MAX_RK4_STEPS`].
pub fn check_work(
    m: &Motor,
    cfg: &SimConfig,
    duration_s: f64,
    edges: u64,
) -> Result<f64, SimError> {
    let simulated_s = duration_s + settle_max(m, cfg);
    let steps = (simulated_s / cfg.dt).ceil() + edges as f64;
    if steps.is_nan() || steps > MAX_RK4_STEPS {
        return Err(SimError::TooMuchWork {
            steps,
            simulated_s,
            dt: cfg.dt,
            max: MAX_RK4_STEPS,
        });
    }
    Ok(steps)
}

/// Runs one move: `edges` are the step edges in ticks of `clock_hz`; the move goes in the
/// negative direction when `direction` < 0, else in the positive one. An edge stream whose
/// run would pass [`MAX_RK4_STEPS`] stops there with an error.
pub fn run<I: Iterator<Item = u64>>(
    m: &Motor,
    cfg: &SimConfig,
    edges: I,
    clock_hz: f64,
    direction: f64,
) -> Result<SimResult, SimError> {
    check_inputs(m, cfg, clock_hz)?;
    run_checked(m, cfg, edges, clock_hz, direction, None)
}

/// [`run`] for a move known in advance to last `duration_s` with `steps` edges: its work
/// is checked before it starts, and a long run shows progress when `cfg.progress` is set.
pub fn run_planned<I: Iterator<Item = u64>>(
    m: &Motor,
    cfg: &SimConfig,
    edges: I,
    clock_hz: f64,
    direction: f64,
    (duration_s, steps): (f64, u64),
) -> Result<SimResult, SimError> {
    check_inputs(m, cfg, clock_hz)?;
    let work = check_work(m, cfg, duration_s, steps)?;
    run_checked(m, cfg, edges, clock_hz, direction, Some(work))
}

fn run_checked<I: Iterator<Item = u64>>(
    m: &Motor,
    cfg: &SimConfig,
    edges: I,
    clock_hz: f64,
    direction: f64,
    work: Option<f64>,
) -> Result<SimResult, SimError> {
    let bar = work
        .filter(|&w| cfg.progress && w > PROGRESS_STEPS)
        .map(|w| {
            let b = crate::progress::progress(w as u64);
            b.set_message("simulating");
            b
        });
    let dir = if direction < 0.0 { -1.0 } else { 1.0 };
    let p = Plant::new(m, &cfg.driver, dir);
    let r = match cfg.driver.mode {
        DriverMode::Rl => run_mode::<false, I>(&p, m, cfg, edges, clock_hz, dir, bar.as_ref()),
        DriverMode::Ideal => run_mode::<true, I>(&p, m, cfg, edges, clock_hz, dir, bar.as_ref()),
    };
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    r
}

/// Why the state at a grid point is no result: not finite, or the electrical angle turning
/// faster per step than RK4 can follow. `None` while the integration holds.
fn divergence(nr: f64, x: &State, dt: f64) -> Option<String> {
    if !x.iter().all(|v| v.is_finite()) {
        return Some(format!(
            "the state is no longer finite (θ = {} rad, ω = {} rad/s, i_A = {} A, i_B = {} A)",
            Num(x[TH]),
            Num(x[OM]),
            Num(x[IA]),
            Num(x[IB])
        ));
    }
    let turn = nr * x[OM].abs() * dt;
    if turn > RK4_IMAGINARY_BOUND {
        return Some(format!(
            "the rotor reached {:.1} rad/s, where the electrical angle turns N_r·|ω|·dt = {:.3} rad \
             per step, past RK4's stability bound 2√2 (a smaller dt follows faster motion)",
            Num(x[OM].abs()),
            turn
        ));
    }
    None
}

fn run_mode<const IDEAL: bool, I: Iterator<Item = u64>>(
    p: &Plant,
    m: &Motor,
    cfg: &SimConfig,
    mut edges: I,
    clock: f64,
    dir: f64,
    bar: Option<&ProgressBar>,
) -> Result<SimResult, SimError> {
    let dt = cfg.dt;
    let micro = m.microstep_angle(cfg.driver.microsteps);
    let full_step = micro * cfg.driver.microsteps as f64;
    let wn = m.natural_frequency(cfg.driver.current);
    let zeta = m.effective_damping_ratio(cfg.driver.current);
    let settle_max = settle_max(m, cfg);
    // ω* over [e_prev, e_next): one microstep per period, as the field moves (0 after the end).
    let omega_ref = |from: u64, to: Option<u64>| match to {
        Some(e) => dir * micro * clock / (e.saturating_sub(from).max(1)) as f64,
        None => 0.0,
    };

    let mut x: State = [0.0; NSTATE];
    let mut next = edges.next();
    let mut after = edges.next();
    // i_A* = I·cos(N_r θ*), i_B* = I·sin(N_r θ*) (DESIGN.md §4), from the driver's table.
    let table = SineTable::new(cfg.driver.current, cfg.driver.microsteps);
    let command = |count: u64, omega_ref: f64| {
        let (ia_ref, ib_ref) = table.at(count, dir);
        Command {
            ia_ref,
            ib_ref,
            omega_ref,
        }
    };
    let mut u = command(0, omega_ref(0, next));
    x[IA] = u.ia_ref;
    x[IB] = u.ib_ref;
    // PI integrators start at the steady holding voltage R·i: no start-up transient.
    x[ZA] = p.r * u.ia_ref;
    x[ZB] = p.r * u.ib_ref;
    let stored0 = p.stored_energy(&x);

    let mut meas = Measures::new(p.nr);
    let mut count: u64 = 0;
    let mut t = 0.0;
    let mut k: u64 = 0;
    let mut last_edge_t = 0.0;
    let trace_every = cfg
        .trace_interval
        .map(|ti| ((ti / dt).round() as u64).max(1));
    let mut trace = Vec::new();
    let err_of = |count: u64, x: &State| count as f64 * micro - dir * x[TH];
    loop {
        let t_grid = (k + 1) as f64 * dt;
        while let Some(e) = next {
            let te = e as f64 / clock;
            if te > t_grid {
                break;
            }
            if te > t {
                rk4::<IDEAL>(p, &mut x, &u, te - t);
                t = te;
            }
            count += 1;
            next = after;
            after = edges.next();
            if let Some(n) = next {
                if n < e {
                    return Err(SimError::EdgesBackwards { prev: e, next: n });
                }
            }
            u = command(count, omega_ref(e, next));
            last_edge_t = te;
        }
        rk4::<IDEAL>(p, &mut x, &u, t_grid - t);
        t = t_grid;
        k += 1;
        if let Some(what) = divergence(p.nr, &x, dt) {
            return Err(SimError::Diverged { t, what });
        }
        if k.is_multiple_of(1 << 16) {
            if (k + count) as f64 > MAX_RK4_STEPS {
                return Err(SimError::WorkLimit {
                    t,
                    dt,
                    max: MAX_RK4_STEPS,
                });
            }
            if let Some(b) = bar {
                b.set_position(k + count);
            }
        }
        let err = err_of(count, &x);
        meas.observe(t, err, x[OM]);
        if let Some(n) = trace_every {
            if k.is_multiple_of(n) {
                let (ia, ib) = if IDEAL {
                    (u.ia_ref, u.ib_ref)
                } else {
                    (x[IA], x[IB])
                };
                trace.push(TraceRow {
                    t,
                    commanded_deg: (count as f64 * micro).to_degrees(),
                    actual_deg: (dir * x[TH]).to_degrees(),
                    // the step rate of the edge interval in progress (one microstep per period)
                    commanded_speed_deg_s: (dir * u.omega_ref).to_degrees(),
                    actual_speed_deg_s: (dir * x[OM]).to_degrees(),
                    error_deg: err.to_degrees(),
                    ia,
                    ib,
                });
            }
        }
        if cfg.stop_at_first_loss && meas.first_loss.is_some() {
            break;
        }
        if next.is_none() {
            let since = t - last_edge_t;
            let amplitude = meas.deviation(err).hypot(x[OM] / wn);
            if since >= settle_max
                || (since >= 1e-3 && amplitude < cfg.settle_tolerance * full_step)
            {
                break;
            }
        }
    }
    let final_error = err_of(count, &x);
    let energy = if IDEAL {
        None
    } else {
        Some(EnergyBalance {
            electrical_input_j: x[E_IN],
            copper_loss_j: x[E_CU],
            mechanical_work_j: x[E_MECH],
            stored_change_j: p.stored_energy(&x) - stored0,
        })
    };
    let lost_cycles = meas.cycles_lost(final_error);
    Ok(SimResult {
        steps: count,
        microsteps: cfg.driver.microsteps,
        mode: cfg.driver.mode,
        lost_steps: lost_cycles * 4 * cfg.driver.microsteps as i64,
        lost: lost_cycles != 0 || meas.first_loss.is_some(),
        first_loss_s: meas.first_loss,
        peak_following_error_deg: meas.peak_abs().to_degrees(),
        min_following_error_deg: meas.min_error.to_degrees(),
        max_following_error_deg: meas.max_error.to_degrees(),
        final_error_deg: final_error.to_degrees(),
        peak_following_error_steps: meas.peak_abs() / micro,
        move_time_s: last_edge_t,
        simulated_s: t,
        dt_s: dt,
        damping_ratio: zeta,
        natural_frequency_hz: wn / std::f64::consts::TAU,
        peak_speed_deg_s: meas.peak_speed.to_degrees(),
        energy,
        trace,
    })
}

/// A move's edges need not be known in advance: the same integration as [`run`], fed one
/// edge at a time as it happens (hardware in the loop), in either direction.
///
/// The command after an edge holds ω* over the interval to the *next* edge, so an edge is
/// integrated past only once the next one is known; until then the rotor is integrated
/// provisionally as after a move's last edge (ω* = 0), and redone when the next edge comes.
/// An edge followed by no other within [`Incremental::HOLD_S`] is taken as its move's last.
/// For one move in one direction the trajectory equals [`run`]'s, grid point by grid point.
#[derive(Clone, Debug)]
pub struct Incremental {
    plants: [Plant; 2],
    table: SineTable,
    ideal: bool,
    dt: f64,
    micro: f64,
    clock: f64,
    /// Integrated up to just before `pending`'s tick.
    done: Stepper,
    /// The last edge fed, not yet applied: (tick, −1 / 0 / +1).
    pending: (u64, i64),
    /// `pending` is no edge but where a long quiet time was committed (ω* stays 0).
    at_rest: bool,
    /// `done` with `pending` applied as a move's last edge, integrated further.
    ahead: Option<Stepper>,
    /// Committed grid points (t, rotor angle in the move's frame), when recording.
    pub trace: Option<Vec<(f64, f64)>>,
}

/// The integrator's state at a point of time.
#[derive(Clone, Copy, Debug)]
struct Stepper {
    x: State,
    u: Command,
    t: f64,
    k: u64,
    pos: i64,
    /// The direction of the last edge: +1 or −1 (the load opposes it).
    dir: f64,
}

impl Incremental {
    /// The longest gap after which an edge counts as its move's last (s).
    pub const HOLD_S: f64 = 0.05;

    /// A rotor at rest at position 0, energized, at tick 0 of a `clock_hz` clock.
    pub fn new(m: &Motor, cfg: &SimConfig, clock_hz: f64) -> Result<Incremental, SimError> {
        check_inputs(m, cfg, clock_hz)?;
        let plants = [
            Plant::new(m, &cfg.driver, 1.0),
            Plant::new(m, &cfg.driver, -1.0),
        ];
        let table = SineTable::new(cfg.driver.current, cfg.driver.microsteps);
        let (ia_ref, ib_ref) = table.at(0, 1.0);
        let u = Command {
            ia_ref,
            ib_ref,
            omega_ref: 0.0,
        };
        let mut x: State = [0.0; NSTATE];
        x[IA] = ia_ref;
        x[IB] = ib_ref;
        x[ZA] = plants[0].r * ia_ref;
        x[ZB] = plants[0].r * ib_ref;
        Ok(Incremental {
            plants,
            table,
            ideal: cfg.driver.mode == DriverMode::Ideal,
            dt: cfg.dt,
            micro: m.microstep_angle(cfg.driver.microsteps),
            clock: clock_hz,
            done: Stepper {
                x,
                u,
                t: 0.0,
                k: 0,
                pos: 0,
                dir: 1.0,
            },
            pending: (0, 0),
            at_rest: false,
            ahead: None,
            trace: None,
        })
    }

    /// One STEP edge at `tick` (not before the previous one) in the direction `forward`.
    pub fn edge(&mut self, tick: u64, forward: bool) -> Result<(), SimError> {
        let (prev, _) = self.pending;
        if tick < prev {
            return Err(SimError::EdgesBackwards { prev, next: tick });
        }
        let held = (tick - prev) as f64 / self.clock > Self::HOLD_S;
        let d = if forward { 1 } else { -1 };
        let mut s = self.done;
        self.apply_pending(&mut s, (!held).then_some((tick, d)), true);
        self.done = s;
        self.pending = (tick, d);
        self.at_rest = false;
        self.ahead = None;
        Ok(())
    }

    /// Integrates (provisionally past the last edge) up to the last grid point at or
    /// before `tick`.
    pub fn advance_to(&mut self, tick: u64) {
        let te = tick as f64 / self.clock;
        let mut s = match self.ahead {
            Some(s) => s,
            None => {
                let mut s = self.done;
                self.apply_pending(&mut s, None, false);
                s
            }
        };
        while ((s.k + 1) as f64 * self.dt) <= te {
            let t_grid = (s.k + 1) as f64 * self.dt;
            let h = t_grid - s.t;
            self.rk4(&mut s, h);
            s.t = t_grid;
            s.k += 1;
        }
        // a long quiet time: the pending edge was its move's last, for good
        if te - self.pending.0 as f64 / self.clock > Self::HOLD_S {
            self.done = s;
            self.pending = (tick, 0);
            self.at_rest = true;
            self.ahead = None;
            return;
        }
        self.ahead = Some(s);
    }

    /// Integrates `s` along the grid to the pending edge and applies it, with ω* to
    /// `next` (tick and direction; none: the move's last edge, ω* = 0). With `commit`,
    /// records the trace.
    fn apply_pending(&mut self, s: &mut Stepper, next: Option<(u64, i64)>, commit: bool) {
        let (e, d) = self.pending;
        let te = e as f64 / self.clock;
        loop {
            let t_grid = (s.k + 1) as f64 * self.dt;
            if te <= t_grid {
                break;
            }
            self.rk4(s, t_grid - s.t);
            s.t = t_grid;
            s.k += 1;
            if commit {
                if let Some(tr) = self.trace.as_mut() {
                    tr.push((t_grid, s.dir * s.x[TH]));
                }
            }
        }
        if te > s.t {
            self.rk4(s, te - s.t);
            s.t = te;
        }
        if d != 0 {
            s.pos += d;
            s.dir = d as f64;
        }
        let next = next.filter(|_| !self.at_rest);
        if let (0, Some((_, nd))) = (d, next) {
            // the start of a move: it goes the way of its first edge
            s.dir = nd as f64;
        }
        let omega_ref = match next.map(|(n, _)| n) {
            Some(n) => s.dir * self.micro * self.clock / (n.saturating_sub(e).max(1)) as f64,
            None => 0.0,
        };
        let (ia_ref, ib_ref) = self
            .table
            .at(s.pos.unsigned_abs(), if s.pos < 0 { -1.0 } else { 1.0 });
        s.u = Command {
            ia_ref,
            ib_ref,
            omega_ref,
        };
    }

    /// Lets time pass to `tick` without integrating: for a rotor at rest, whose state no
    /// longer changes (the pending edge is taken as its move's last).
    pub fn rest_to(&mut self, tick: u64) {
        let mut s = match self.ahead {
            Some(s) => s,
            None => {
                let mut s = self.done;
                self.apply_pending(&mut s, None, false);
                s
            }
        };
        let k = ((tick as f64 / self.clock) / self.dt).floor() as u64;
        if k > s.k {
            s.k = k;
            s.t = k as f64 * self.dt;
        }
        self.done = s;
        self.pending = (tick.max(self.pending.0), 0);
        self.at_rest = true;
        self.ahead = None;
    }

    fn rk4(&self, s: &mut Stepper, h: f64) {
        let p = &self.plants[usize::from(s.dir < 0.0)];
        if self.ideal {
            rk4::<true>(p, &mut s.x, &s.u, h)
        } else {
            rk4::<false>(p, &mut s.x, &s.u, h)
        }
    }

    fn latest(&self) -> &Stepper {
        self.ahead.as_ref().unwrap_or(&self.done)
    }

    /// The rotor's position in microsteps (0 at the start) at the latest time integrated.
    pub fn rotor_microsteps(&self) -> f64 {
        self.latest().x[TH] / self.micro
    }

    /// The commanded position: edges fed, forward minus backward.
    pub fn commanded(&self) -> i64 {
        self.done.pos + self.pending.1
    }

    /// The rotor speed (rad/s) at the latest time integrated.
    pub fn speed(&self) -> f64 {
        self.latest().x[OM]
    }

    /// The latest time integrated (s).
    pub fn time(&self) -> f64 {
        self.latest().t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_state_that_is_not_finite_or_too_fast_is_a_divergence() {
        let mut x: State = [0.0; NSTATE];
        x[OM] = 100.0;
        assert_eq!(divergence(50.0, &x, 1e-6), None);
        x[E_IN] = f64::NAN;
        assert!(divergence(50.0, &x, 1e-6)
            .unwrap()
            .contains("no longer finite"));
        x[E_IN] = 0.0;
        x[IA] = f64::INFINITY;
        assert!(divergence(50.0, &x, 1e-6).unwrap().contains("i_A = inf"));
        x[IA] = 0.0;
        // N_r·|ω|·dt = 50 · 6e4 · 1e-6 = 3 > 2√2, in either direction
        x[OM] = -6e4;
        let why = divergence(50.0, &x, 1e-6).unwrap();
        assert!(
            why.contains("60000.0 rad/s") && why.contains("3.000 rad"),
            "{why}"
        );
    }
}
