use super::super::exactly_once::launch;
use super::super::model::{Model, ModelPort};
use super::super::{Opener, Port};
use super::*;
use crate::backend::{BoardBackend, SyncLine};
use std::sync::{Arc, Mutex};

const TOKEN: u32 = 0x5EED_0001;

fn kept(streamed: u32) -> LinkSession {
    LinkSession {
        token: TOKEN,
        offsets: vec![0, 0],
        streamed,
        armed: 0,
        folding: None,
        rolled: 0,
    }
}

fn model(set: impl FnOnce(&mut Model)) -> Arc<Mutex<Model>> {
    let mut m = Model::default();
    set(&mut m);
    Arc::new(Mutex::new(m))
}

/// Every session the backend kept, in order.
type Kept = Arc<Mutex<Vec<LinkSession>>>;

/// A backend connecting to `m` with the session `before`.
fn resume(m: &Arc<Mutex<Model>>, before: Option<LinkSession>) -> (FpgaBackend, Kept) {
    let port = m.clone();
    let open: Opener = Box::new(move || Ok(Box::new(ModelPort(port.clone())) as Box<dyn Port>));
    let mut b = FpgaBackend::with_opener_resuming("model".into(), open, 2, before)
        .expect("the model answers");
    let log = Arc::new(Mutex::new(Vec::new()));
    let l = log.clone();
    b.keep_session(Box::new(move |s| {
        l.lock().unwrap().push(s.clone());
        Ok(())
    }));
    (b, log)
}

fn events(b: &mut FpgaBackend) -> Vec<(usize, PinEvent)> {
    b.begin_advance();
    std::iter::from_fn(|| b.poll(1)).collect()
}

/// Polls until `f` holds of the model (the link is tried again every 500 ms).
fn poll_until(
    b: &mut FpgaBackend,
    m: &Arc<Mutex<Model>>,
    f: impl Fn(&Model) -> bool,
) -> Vec<(usize, PinEvent)> {
    let deadline = Instant::now() + Duration::from_secs(20);
    let mut all = Vec::new();
    while !f(&m.lock().unwrap()) {
        assert!(Instant::now() < deadline, "never happened: {all:?}");
        all.extend(events(b));
        std::thread::yield_now();
    }
    all.extend(events(b));
    all
}

/// A host restarted while its board runs axis 0 forward (700 steps to go, the counter at
/// 100) with the session it kept (axis 0's offset 3600).
fn adopting_a_running_move() -> (Arc<Mutex<Model>>, FpgaBackend, Kept) {
    let m = model(|m| {
        (m.session, m.busy, m.dir) = (TOKEN, 0b01, 0b01);
        (m.position, m.steps) = ([100, 5], 700);
    });
    let mut before = kept(0);
    before.offsets = vec![3600, 0];
    let (b, log) = resume(&m, Some(before));
    (m, b, log)
}

#[test]
fn a_board_that_lost_power_while_the_host_was_down_untrusts_every_axis() {
    // power-up values: Session 0, the counts 0 as the store has them
    let m = Arc::new(Mutex::new(Model::default()));
    let (mut b, log) = resume(&m, Some(kept(0)));
    assert!(!b.adopted());
    let token = m.lock().unwrap().session;
    assert!(token != 0 && token != TOKEN, "claimed anew");
    // the new token is kept only once the loss is told (and so stored by the board)
    let kept_new = || log.lock().unwrap().iter().any(|s| s.token == token);
    b.begin_advance();
    let first = b.poll(1).expect("the loss is told");
    assert!(!kept_new(), "kept before the loss was told");
    let ev: Vec<_> = std::iter::once(first)
        .chain(std::iter::from_fn(|| b.poll(1)))
        .collect();
    let lost: Vec<usize> = ev
        .iter()
        .filter_map(|(i, e)| match e {
            PinEvent::Lost { why } if why.contains("while the host was down") => Some(*i),
            _ => None,
        })
        .collect();
    assert_eq!(lost, [0, 1], "{ev:?}");
    let deadline = Instant::now() + Duration::from_secs(20);
    while !kept_new() {
        assert!(Instant::now() < deadline, "the claim was never kept");
        events(&mut b);
        std::thread::yield_now();
    }
    assert_eq!(log.lock().unwrap().last().map(|s| s.token), Some(token));
}

/// A host killed while folding an idle axis's offset into the board's counter, before
/// or after the register write: the next one adopts the same count either way.
#[test]
fn a_host_killed_mid_fold_adopts_the_count_whichever_write_the_board_got() {
    for register in [100, 3700] {
        let m = model(|m| {
            m.session = TOKEN;
            m.position = [register, 5];
        });
        let mut before = kept(0);
        before.offsets = vec![3600, 0];
        before.folding = Some(Fold {
            axis: 0,
            register: 100,
            offset: 3600,
        });
        let (mut b, log) = resume(&m, Some(before));
        assert!(b.adopted());
        assert_eq!(b.count(0), 3700, "register {register}");
        events(&mut b);
        assert_eq!(m.lock().unwrap().position[0], 3700, "folded in once");
        assert_eq!(b.count(0), 3700);
        let last = log.lock().unwrap().last().cloned().unwrap();
        assert_eq!((last.offsets, last.folding), (vec![0, 0], None));
    }
}

/// An idle axis adopted with an offset: the fold is kept before the register is
/// written (a host that dies before it could keep anything leaves the offset kept).
#[test]
fn an_adopted_idle_offset_is_folded_in_only_once_the_session_is_kept() {
    let m = model(|m| {
        m.session = TOKEN;
        m.position = [100, 5];
    });
    let mut before = kept(0);
    before.offsets = vec![3600, 0];
    let port = m.clone();
    let open: Opener = Box::new(move || Ok(Box::new(ModelPort(port.clone())) as Box<dyn Port>));
    let mut b = FpgaBackend::with_opener_resuming("model".into(), open, 2, Some(before))
        .expect("the model answers");
    assert_eq!(b.count(0), 3700);
    events(&mut b);
    assert_eq!(
        m.lock().unwrap().position[0],
        100,
        "no session kept: not folded"
    );
    let log = Arc::new(Mutex::new(Vec::new()));
    let l = log.clone();
    b.keep_session(Box::new(move |s| {
        l.lock().unwrap().push(s.clone());
        Ok(())
    }));
    poll_until(&mut b, &m, |m| m.position[0] == 3700);
    assert_eq!(b.count(0), 3700);
    let log = log.lock().unwrap();
    let fold = log.iter().position(|s| s.folding.is_some());
    let done = log
        .iter()
        .rposition(|s| s.folding.is_none() && s.offsets[0] == 0);
    assert!(
        fold.is_some() && done > fold,
        "kept before and after: {log:?}"
    );
}

/// A periodic axis wrapped while it runs: the host's reading shifts at once, the kept
/// session only once the axis rests (no durable write per wrap; a host killed meanwhile
/// reads the same place, whole periods off).
/// Any other shift of a running count (`rebase`) is kept at once, the wraps left out.
#[test]
fn a_wrap_while_the_axis_runs_is_kept_once_it_rests() {
    let (m, mut b, log) = adopting_a_running_move();
    assert!(events(&mut b).is_empty(), "still moving");
    b.wrap(0, -3240).unwrap();
    assert_eq!(b.count(0), 460, "the reading shifts at once");
    assert!(events(&mut b).is_empty(), "still moving");
    let offsets =
        |log: &Kept| -> Vec<i64> { log.lock().unwrap().iter().map(|s| s.offsets[0]).collect() };
    assert!(
        offsets(&log).iter().all(|&o| o == 3600),
        "kept mid-motion: {:?}",
        offsets(&log)
    );
    b.rebase(0, 10, false).unwrap();
    assert_eq!(b.count(0), 470);
    assert_eq!(
        offsets(&log).last(),
        Some(&3610),
        "a re-reference, kept at once"
    );
    m.lock().unwrap().finish();
    let ev = events(&mut b);
    assert!(matches!(ev[..], [(0, PinEvent::End { .. })]), "{ev:?}");
    assert_eq!(b.count(0), 1170);
    assert_eq!(m.lock().unwrap().position[0], 1170, "folded in at rest");
    let log = log.lock().unwrap();
    let fold = log
        .iter()
        .position(|s| s.folding.is_some_and(|f| f.offset == 370));
    assert!(
        fold.is_some(),
        "the wrapped offset kept before the fold: {log:?}"
    );
    assert_eq!(log.last().unwrap().offsets, vec![0, 0]);
}

#[test]
fn a_restarted_host_adopts_a_running_computed_move_and_trusts_its_end() {
    let (m, mut b, _) = adopting_a_running_move();
    assert!(b.adopted());
    assert_eq!(m.lock().unwrap().session, TOKEN, "the session kept");
    assert_eq!(b.adopted_motion(0), Some(1), "running forward");
    assert_eq!(b.adopted_motion(1), None);
    assert_eq!(
        (b.count(0), b.count(1)),
        (3700, 5),
        "counter plus the kept offset"
    );
    assert!(events(&mut b).is_empty(), "still moving");
    m.lock().unwrap().finish();
    let ev = events(&mut b);
    assert!(matches!(ev[..], [(0, PinEvent::End { .. })]), "{ev:?}");
    assert_eq!(b.count(0), 4400);
    assert_eq!(
        m.lock().unwrap().position[0],
        4400,
        "the offset folded in at rest"
    );
    // a new move after it
    let l = launch(&b, 0, 100);
    b.start(vec![l], None, &Default::default(), 2).unwrap();
    assert_eq!(m.lock().unwrap().starts, 1);
}

#[test]
fn a_restarted_host_halts_a_streamed_move_at_once() {
    let m = model(|m| (m.session, m.busy, m.position) = (TOKEN, 0b10, [0, -42]));
    let (mut b, _) = resume(&m, Some(kept(0b10)));
    assert_eq!(m.lock().unwrap().busy, 0, "halted");
    assert_eq!(b.adopted_motion(1), None);
    let ev = events(&mut b);
    assert!(
        matches!(&ev[..], [(1, PinEvent::Late { why })] if why.starts_with("host_restarted")),
        "{ev:?}"
    );
    assert_eq!(b.count(1), -42, "the count exact");
}

#[test]
fn an_armed_group_is_disarmed_when_its_link_comes_back_and_never_fires() {
    let m = Arc::new(Mutex::new(Model::default()));
    let (mut b, log) = resume(&m, None);
    let l = launch(&b, 0, 300);
    b.arm(vec![l], 0).unwrap();
    assert!(m.lock().unwrap().armed);
    assert_eq!(log.lock().unwrap().last().map(|s| s.armed), Some(0b01));
    // the link is cut: a stop cannot reach the board
    m.lock().unwrap().cut = true;
    assert!(b.stop(0, 1).is_err());
    assert!(b.fault(0).is_some(), "the link is down");
    m.lock().unwrap().cut = false;
    let ev = poll_until(&mut b, &m, |m| !m.armed);
    assert!(
        ev.iter()
            .any(|(i, e)| *i == 0
                && matches!(e, PinEvent::Late { why } if why.starts_with("disarmed"))),
        "{ev:?}"
    );
    assert!(b.fault(0).is_none(), "the link is back");
    assert_eq!(b.end_tick(0), None, "no longer moving");
    // a later group fired on another board alone: nothing starts here
    let starts = m.lock().unwrap().starts;
    m.lock().unwrap().sync_fall();
    assert_eq!(m.lock().unwrap().starts, starts);
    assert_eq!(log.lock().unwrap().last().map(|s| s.armed), Some(0));
}

#[test]
fn an_armed_group_not_fired_within_its_lifetime_is_disarmed() {
    let m = Arc::new(Mutex::new(Model::default()));
    let (mut b, _) = resume(&m, None);
    b.arm_lifetime = Duration::ZERO;
    let l = launch(&b, 1, 300);
    b.arm(vec![l], 0).unwrap();
    let ev = events(&mut b);
    assert!(!m.lock().unwrap().armed, "{ev:?}");
    assert!(
        matches!(&ev[..], [(1, PinEvent::End { .. }), (1, PinEvent::Late { why })]
            if why.contains("not fired within")),
        "{ev:?}"
    );
}

/// Every `Arm` goes with the board's own bound (the host's lifetime and half again, in
/// the board's clocks); a share the board cut is told as `arm_expired` on its axes,
/// and a later fire from another board starts nothing here.
#[test]
fn a_share_the_board_cut_after_its_arm_timeout_is_told_as_arm_expired() {
    let m = Arc::new(Mutex::new(Model::default()));
    let (mut b, _) = resume(&m, None);
    let l = launch(&b, 1, 300);
    b.arm(vec![l], 0).unwrap();
    // 30 s * 1.5 at the model's 50 MHz
    assert_eq!(m.lock().unwrap().arm_timeout, Some(2_250_000_000));
    assert!(events(&mut b).is_empty(), "armed, nothing told yet");
    m.lock().unwrap().arm_expire();
    assert_eq!(m.lock().unwrap().busy, 0, "the board cut the share");
    let ev = events(&mut b);
    assert!(
        matches!(&ev[..], [(1, PinEvent::End { .. }), (1, PinEvent::Late { why })]
            if why.starts_with("arm_expired") && why.contains("45 s")),
        "{ev:?}"
    );
    assert!(events(&mut b).is_empty(), "told once");
    let starts = m.lock().unwrap().starts;
    m.lock().unwrap().sync_fall();
    assert_eq!(m.lock().unwrap().starts, starts);
    // a lifetime past what the register holds asks for its largest bound
    b.arm_lifetime = Duration::from_secs(3600);
    let l = launch(&b, 0, 300);
    b.arm(vec![l], 0).unwrap();
    assert_eq!(m.lock().unwrap().arm_timeout, Some(u32::MAX));
}

#[test]
fn a_restarted_host_tells_a_share_the_board_cut_meanwhile_as_arm_expired() {
    let m = model(|m| (m.session, m.arm_expired) = (TOKEN, true));
    let mut before = kept(0);
    before.armed = 0b10;
    let (mut b, _) = resume(&m, Some(before));
    let ev = events(&mut b);
    assert!(
        matches!(&ev[..], [(1, PinEvent::Late { why })] if why.starts_with("arm_expired")),
        "{ev:?}"
    );
    assert_eq!(b.end_tick(1), None, "not moving");
}

#[test]
fn a_restarted_host_disarms_the_group_it_left_armed() {
    let m = model(|m| (m.session, m.busy, m.armed) = (TOKEN, 0b11, true));
    let mut before = kept(0);
    before.armed = 0b11;
    let (mut b, _) = resume(&m, Some(before));
    assert!(!m.lock().unwrap().armed);
    assert_eq!(m.lock().unwrap().busy, 0);
    let ev = events(&mut b);
    assert_eq!(ev.len(), 2, "{ev:?}");
    assert!(ev
        .iter()
        .all(|(_, e)| matches!(e, PinEvent::Late { why } if why.starts_with("disarmed"))));
}

#[test]
fn a_group_armed_before_the_first_connect_is_disarmed() {
    let m = model(|m| (m.busy, m.armed) = (0b10, true));
    let (mut b, _) = resume(&m, None);
    assert!(!m.lock().unwrap().armed, "disarmed at connect");
    let ev = events(&mut b);
    assert!(
        matches!(&ev[..], [(1, PinEvent::Late { why })] if why.contains("before this host")),
        "{ev:?}"
    );
}

/// The whole board on the model: a host killed mid-move comes back with the axis
/// `moving` (not idle, not untrusted), and it ends trusted at the board's count.
#[test]
fn a_restarted_board_shows_the_adopted_axis_moving_then_trusted_at_its_end() {
    use crate::axis::AxisState;
    use crate::store::{AxisRecord, MovingMarker, Store};
    use crate::{Board, BoardConfig};
    let dir = tempfile::tempdir().unwrap();
    let config = BoardConfig::parse(
        "[board]\nname = \"t\"\n[[axis]]\nname = \"X\"\n[[axis]]\nname = \"Y\"\n",
    )
    .unwrap();
    let store = Store::open(dir.path()).unwrap();
    let rec = AxisRecord {
        position: 100,
        homed: true,
        trusted: true,
        moving: Some(MovingMarker {
            from: 100,
            target: 800,
            homing: false,
        }),
        sim_position: 0,
        slack: 0,
    };
    store.put_axis("X", &rec).unwrap();
    store.put_link_session(&kept(0)).unwrap();
    let m = model(|m| {
        (m.session, m.busy, m.dir) = (TOKEN, 0b01, 0b01);
        (m.position, m.steps) = ([400, 0], 400);
    });
    let port = m.clone();
    let open: Opener = Box::new(move || Ok(Box::new(ModelPort(port.clone())) as Box<dyn Port>));
    let before = store.link_session().unwrap();
    let pins = FpgaBackend::with_opener_resuming("model".into(), open, 2, before).unwrap();
    let mut board = Board::open_with(&config, store, Box::new(pins)).unwrap();
    let x = board.status(&["X".into()], 1).unwrap().remove(0);
    assert_eq!(
        (x.state, x.position, x.trusted),
        (AxisState::Moving, 400, true),
        "{x:?}"
    );
    m.lock().unwrap().finish();
    let x = board.status(&["X".into()], 2).unwrap().remove(0);
    assert_eq!(
        (x.state, x.position, x.trusted, x.homed),
        (AxisState::Idle, 800, true, true),
        "{x:?}"
    );
}

/// A host killed mid-homing: the restarted one cannot finish it (its phases lived in
/// the host that died), so the axis is halted and untrusted, never trusted at a count
/// no homing re-referenced; between two phases (the board idle) as well.
#[test]
fn a_homing_adopted_from_the_host_before_is_halted_and_untrusted() {
    use crate::axis::AxisState;
    use crate::store::{AxisRecord, MovingMarker, Store};
    use crate::{Board, BoardConfig};
    for running in [true, false] {
        let dir = tempfile::tempdir().unwrap();
        let config = BoardConfig::parse(
            "[board]\nname = \"t\"\n[[axis]]\nname = \"X\"\n[[axis]]\nname = \"Y\"\n",
        )
        .unwrap();
        let store = Store::open(dir.path()).unwrap();
        // as homing writes it: trusted from before, not homed, the marker a homing's
        let rec = AxisRecord {
            position: 100,
            homed: false,
            trusted: true,
            moving: Some(MovingMarker {
                from: 100,
                target: -3900,
                homing: true,
            }),
            ..AxisRecord::default()
        };
        store.put_axis("X", &rec).unwrap();
        store.put_link_session(&kept(0)).unwrap();
        let m = model(|m| {
            (m.session, m.busy, m.dir) = (TOKEN, running as u32, 0);
            (m.position, m.steps) = ([40, 0], 4000);
        });
        let port = m.clone();
        let open: Opener = Box::new(move || Ok(Box::new(ModelPort(port.clone())) as Box<dyn Port>));
        let before = store.link_session().unwrap();
        let pins = FpgaBackend::with_opener_resuming("model".into(), open, 2, before).unwrap();
        let mut board = Board::open_with(&config, store, Box::new(pins)).unwrap();
        assert_eq!(m.lock().unwrap().busy, 0, "halted (running: {running})");
        let x = board.status(&["X".into()], 1).unwrap().remove(0);
        assert_eq!(
            (x.state, x.position, x.trusted, x.homed),
            (AxisState::Fault, 40, false, false),
            "running: {running}: {x:?}"
        );
        let why = x.fault.unwrap_or_default();
        assert!(
            why.starts_with("host_restarted") && why.contains("homing"),
            "{why}"
        );
        assert!(board.warnings().iter().any(|w| w.contains("mid-homing")));
        let y = board.status(&["Y".into()], 2).unwrap().remove(0);
        assert_eq!(y.state, AxisState::Idle, "the other axis untouched");
    }
}

#[test]
fn an_adopted_motion_that_underruns_is_halted_not_busy_forever() {
    // streamed before the restart, its mask not kept: adopted as computed
    let m = model(|m| (m.session, m.busy, m.position) = (TOKEN, 0b01, [70, 0]));
    let (mut b, _) = resume(&m, Some(kept(0)));
    assert_eq!(b.adopted_motion(0), Some(-1));
    assert!(events(&mut b).is_empty(), "running");
    m.lock().unwrap().underrun = true;
    let ev = events(&mut b);
    assert!(
        matches!(&ev[..], [(0, PinEvent::End { .. }), (0, PinEvent::Late { why })]
            if why.starts_with("host_restarted")),
        "{ev:?}"
    );
    assert_eq!((m.lock().unwrap().busy, b.count(0)), (0, 70));
    assert!(events(&mut b).is_empty(), "told once");
}
