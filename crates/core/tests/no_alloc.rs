//! Planning a move of every family, its peaks and its edge generator allocate nothing:
//! counted by a global allocator that wraps the system's.

use multistep_core::{
    EdgeGenerator, Family, LimitsMove, Move, PhaseMove, Profile, Segment, MAX_PHASE_PIECES,
};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};

struct Counting;

static ALLOCS: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    /// Set on the planning thread only: the test harness allocates on its own threads.
    static COUNTING: Cell<bool> = const { Cell::new(false) };
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        if COUNTING.try_with(Cell::get).unwrap_or(false) {
            ALLOCS.fetch_add(1, Ordering::SeqCst);
        }
        unsafe { System.alloc(l) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        unsafe { System.dealloc(p, l) }
    }
}

#[global_allocator]
static A: Counting = Counting;

#[test]
fn planning_every_family_allocates_nothing() {
    let families = [
        Family::Trapezoid,
        Family::Parabolic,
        Family::Exponential { rho: 0.25 },
        Family::Sine,
        Family::SCurve { phi: 0.5 },
        Family::SCurve4 { phi: 0.3, psi: 0.5 },
    ];
    let segs = [
        Segment {
            v0: 0.0,
            duration: 0.1,
            steps: 50,
        },
        Segment {
            v0: 1000.0,
            duration: 0.1,
            steps: 100,
        },
    ];
    let limits = [
        LimitsMove::trapezoid(100_000, 2e4, 1e5),
        LimitsMove::scurve(100_000, 2e4, 1e5, 1e6),
        LimitsMove::scurve4(100_000, 2e4, 1e5, 1e6, 1e8).with_speeds(100.0, 50.0),
    ];
    // only this thread's allocations count (the harness's threads allocate on their own)
    COUNTING.with(|c| c.set(true));
    let before = ALLOCS.load(Ordering::SeqCst);
    let mut planned = 0;
    let mut peak = 0.0f64;
    for f in families {
        let p = Profile::phase(&PhaseMove::new(10_000, f, 0.1, 0.2, 0.1)).unwrap();
        peak = peak.max(p.peak_speed());
        let g = EdgeGenerator::new(p, 50e6).unwrap();
        planned += g.remaining();
    }
    for m in limits {
        let p = Profile::limits(&m).unwrap();
        peak = peak.max(p.peak_speed());
        planned += p.steps();
        let p = Profile::<MAX_PHASE_PIECES>::limits_in(&m).unwrap();
        planned += p.steps();
        planned += Profile::check_on_clock(&Move::Limits(m), 50e6)
            .unwrap()
            .steps;
    }
    planned += Profile::segments(&segs).unwrap().steps();
    let after = ALLOCS.load(Ordering::SeqCst);
    COUNTING.with(|c| c.set(false));
    assert_eq!(planned, 6 * 10_000 + 3 * 300_000 + 150);
    assert!(peak > 0.0);
    assert_eq!(
        after - before,
        0,
        "planning allocated {} times",
        after - before
    );
}
