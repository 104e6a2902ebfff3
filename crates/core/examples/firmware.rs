//! How firmware uses the core: plan a move once, then drive STEP/DIR from a timer
//! interrupt with [`Stepper::poll`], which sets the pins that are due and returns the next
//! deadline to arm the timer's compare register with. Nothing here allocates or needs
//! `std` from the core (`cargo run -p multistep-core --example firmware --no-default-features`);
//! the pins and the timer are simulated so the example runs on a PC. The edge generator
//! borrows the profile, so an axis holds its pieces once.

use core::convert::Infallible;
use embedded_hal::digital::{ErrorType, OutputPin};
use multistep_core::hal::{edges_for, DriverConfig, PulseShape, StepDirTiming, Stepper, TickTimer};
use multistep_core::{LimitsMove, Profile};

/// A GPIO pin that counts its rising edges (a real board writes a register).
#[derive(Default)]
struct Pin {
    high: bool,
    rises: u32,
}

impl ErrorType for Pin {
    type Error = Infallible;
}

impl OutputPin for Pin {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.high = false;
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Infallible> {
        self.rises += !self.high as u32;
        self.high = true;
        Ok(())
    }
}

/// A 1 MHz free-running counter (a real board reads its timer peripheral).
struct Timer {
    now: u64,
}

impl TickTimer for Timer {
    fn hz(&self) -> u32 {
        1_000_000
    }
    fn now(&mut self) -> u64 {
        self.now
    }
    fn wait_until(&mut self, tick: u64) {
        self.now = self.now.max(tick);
    }
}

fn main() {
    let timer = Timer { now: 0 };

    // 3200 microsteps, S-curve limits: 4000 steps/s, 20 000 steps/s², 400 000 steps/s³
    let m = LimitsMove::scurve(3200, 4000.0, 20_000.0, 400_000.0);
    let profile = Profile::limits(&m).expect("a feasible move");
    // the edges are planned on the timer's own clock; the generator borrows the profile,
    // so the pieces are held once (a static per axis on a small MCU)
    let edges = edges_for(&profile, &timer).expect("fits the clock");
    let memory = (size_of_val(&profile), size_of_val(&edges));

    let cfg = DriverConfig {
        step_dir: StepDirTiming {
            pulse: PulseShape::Fixed { ticks: 2 }, // 2 µs STEP pulses
            dir_setup_ticks: 5,                    // 5 µs DIR setup before the first step
        },
        forward_is_high: true,
    };
    let (mut step, mut dir) = (Pin::default(), Pin::default());
    let mut stepper =
        Stepper::start(&mut step, &mut dir, true, edges, timer.now, cfg).expect("pins work");

    // The interrupt handler: called at each deadline (here: by a loop standing in for the
    // timer compare interrupt).
    let mut now = timer.now;
    let mut interrupts = 0u32;
    while let Some(deadline) = stepper.poll(now).expect("pins work") {
        interrupts += 1;
        now = deadline; // arm the compare register with `deadline`, return from the ISR
    }
    let played = stepper.played();
    let _ = stepper.release();
    assert_eq!(played.steps, 3200);
    assert_eq!(step.rises, 3200);
    println!(
        "{} steps in {:.4} s ({} ticks at 1 MHz), {} interrupts, {} late",
        played.steps,
        now as f64 / 1e6,
        now,
        interrupts,
        played.late
    );
    println!(
        "memory per axis: the profile {} B, the generator borrowing it {} B",
        memory.0, memory.1
    );
}
