use super::model::connect;
use super::*;
use multistep_core::MoveParams;

/// A move of `steps` the board computes.
pub(super) fn launch(b: &FpgaBackend, axis: usize, steps: u64) -> Launch {
    let spec = MoveSpec {
        steps: Some(steps),
        params: MoveParams {
            vmax: Some(4000.0),
            amax: Some(40_000.0),
            ..MoveParams::default()
        },
        ..MoveSpec::default()
    };
    let datapath = b.plan_datapath(&spec, b.params.clock_hz).unwrap();
    assert!(datapath.is_some(), "computed on the board");
    Launch {
        axis,
        profile: spec.plan().unwrap(),
        clock_hz: b.params.clock_hz,
        datapath,
        dir: 1,
        stop_on_sensor: None,
        resync_sensor: true,
    }
}

fn events(b: &mut FpgaBackend, now: u64) -> Vec<(usize, PinEvent)> {
    b.begin_advance();
    std::iter::from_fn(|| b.poll(now)).collect()
}

fn start(b: &mut FpgaBackend, l: Launch) -> Result<(u64, Vec<u64>), CtlError> {
    b.start(vec![l], None, &multistep_core::tdm::TdmConfig::default(), 0)
}

#[test]
fn a_start_whose_reply_is_damaged_runs_once_and_is_tracked() {
    let (mut b, m) = connect();
    m.lock().unwrap().steps = 800;
    let l = launch(&b, 0, 800);
    m.lock().unwrap().damage = Some(Reg::Board(BoardReg::Start).addr());
    let r = start(&mut b, l);
    assert!(r.is_ok(), "the board started it: {r:?}");
    assert_eq!(m.lock().unwrap().starts, 1);
    assert!(b.end_tick(0).is_some(), "tracked as moving");
    assert!(events(&mut b, 1).is_empty(), "still moving");
    m.lock().unwrap().finish();
    let ev = events(&mut b, 2);
    assert!(matches!(ev[..], [(0, PinEvent::End { .. })]), "{ev:?}");
    assert_eq!((b.count(0), b.end_tick(0)), (800, None));
    // the next move is a new start
    let l = launch(&b, 0, 800);
    start(&mut b, l).unwrap();
    m.lock().unwrap().finish();
    events(&mut b, 3);
    assert_eq!((m.lock().unwrap().starts, b.count(0)), (2, 1600));
}

#[test]
fn the_estop_input_and_the_latched_estop_are_told_apart() {
    let (mut b, m) = connect();
    m.lock().unwrap().steps = 300;
    let l = launch(&b, 0, 300);
    start(&mut b, l).unwrap();
    m.lock().unwrap().estop_input = true;
    assert!(
        events(&mut b, 1).is_empty(),
        "the input alone halts nothing here"
    );
    assert!(b.estop_input());
    (
        m.lock().unwrap().estop_input,
        m.lock().unwrap().estop_latched,
    ) = (false, true);
    let ev = events(&mut b, 2);
    assert!(matches!(ev[..], [(0, PinEvent::Estop)]), "{ev:?}");
    assert!(!b.estop_input());
}

#[test]
fn a_power_cycle_untrusts_every_axis_whatever_the_timing() {
    let (mut b, m) = connect();
    m.lock().unwrap().steps = 300;
    let l = launch(&b, 0, 300);
    start(&mut b, l).unwrap();
    assert!(events(&mut b, 1).is_empty());
    // off and on mid-move: every register as at power-up, Session 0 as before
    m.lock().unwrap().power_cycle();
    let ev = events(&mut b, 2);
    let lost: Vec<usize> = ev
        .iter()
        .filter_map(|(i, e)| match e {
            PinEvent::Lost { why } if why.contains("reset or lost power") => Some(*i),
            _ => None,
        })
        .collect();
    assert_eq!(lost, vec![0, 1], "{ev:?}");
    assert!(events(&mut b, 3).is_empty(), "told once");
    let m = m.lock().unwrap();
    assert_ne!(m.session, 0, "claimed again");
    assert_eq!(m.enable, 0b11, "set up again");
}

#[test]
fn a_power_cycle_between_a_polls_reads_is_not_taken_for_the_end_of_the_move() {
    let (mut b, m) = connect();
    m.lock().unwrap().steps = 300;
    let l = launch(&b, 0, 300);
    start(&mut b, l).unwrap();
    // off and on after the poll read Status and Busy: axis 0 then reads idle at 0
    m.lock().unwrap().cycle_in = Some(2);
    let ev = events(&mut b, 1);
    assert!(
        matches!(&ev[..], [(0, PinEvent::Lost { why }), (1, PinEvent::Lost { .. })]
            if why.contains("mid-move")),
        "{ev:?}"
    );
}

#[test]
fn a_start_whose_outcome_stays_unknown_untrusts_its_axes() {
    let (mut b, m) = connect();
    m.lock().unwrap().steps = 300;
    let l = launch(&b, 1, 300);
    m.lock().unwrap().mute = Some(Reg::Board(BoardReg::Start).addr());
    let outcome = m.lock().unwrap().starts;
    assert!(start(&mut b, l).is_err());
    assert_eq!(m.lock().unwrap().starts, outcome + 1, "it did start");
    m.lock().unwrap().mute = None;
    std::thread::sleep(RECONNECT_PERIOD);
    let ev = events(&mut b, 1);
    assert!(
        matches!(&ev[..], [(1, PinEvent::Lost { why })] if why.contains("may or may not")),
        "{ev:?}"
    );
}

/// `estop` latches the board's e-stop (its `Estop` register written 1) and `reset`
/// clears it; a running axis is not moving afterwards.
#[test]
fn estop_latches_the_boards_estop_and_reset_clears_it() {
    let (mut b, m) = connect();
    m.lock().unwrap().steps = 300;
    let l = launch(&b, 0, 300);
    start(&mut b, l).unwrap();
    b.estop(1);
    assert!(
        m.lock().unwrap().estop_latched,
        "the board's e-stop latched"
    );
    assert_eq!(m.lock().unwrap().busy, 0, "the board halted");
    b.clear_estop().unwrap();
    assert!(!m.lock().unwrap().estop_latched, "cleared by reset");
}
