//! The board's 32-bit position registers as the host's 64-bit counts, and what a board
//! reset does to them.

// A position register as a count, and a count at rest as the register's value.
pub(super) use multistep_link::{position_count as count, position_register as register};

use super::FpgaBackend;
use multistep_link::{AxisReg, LinkError, Reg};

impl FpgaBackend {
    /// Reads axis `i`'s position register into its count (the register less the axis's
    /// offset) and returns it.
    pub(super) fn read_count(&mut self, i: usize) -> Result<i64, LinkError> {
        let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
        let raw = l.read(Reg::Axis(i as u32, AxisReg::Position))?;
        let ax = &mut self.axes[i];
        ax.count = count(raw, ax.offset);
        Ok(ax.count)
    }
}

#[cfg(test)]
mod tests {
    use super::super::exactly_once::launch;
    use super::super::model::{connect, Model, ModelPort};
    use super::super::{FpgaBackend, Opener, Port};
    use crate::backend::{BoardBackend, PinEvent};
    use std::sync::{Arc, Mutex};
    use std::time::{Duration, Instant};

    fn events(b: &mut FpgaBackend, now: u64) -> Vec<(usize, PinEvent)> {
        b.begin_advance();
        std::iter::from_fn(|| b.poll(now)).collect()
    }

    #[test]
    fn a_move_backward_ends_at_a_negative_count() {
        let (mut b, m) = connect();
        m.lock().unwrap().steps = -300;
        let l = launch(&b, 0, 300);
        b.start(vec![l], None, &Default::default(), 0).unwrap();
        m.lock().unwrap().position[1] = -42;
        assert!(events(&mut b, 1).is_empty(), "still moving");
        assert_eq!(b.count(1), -42, "an idle axis read while another moves");
        m.lock().unwrap().finish();
        let ev = events(&mut b, 2);
        assert!(matches!(ev[..], [(0, PinEvent::End { .. })]), "{ev:?}");
        assert_eq!(b.count(0), -300);
    }

    /// Axis 0 on a 300-step move, axis 1 at rest at 500, after a first quiet poll.
    fn moving_beside_a_resting_axis() -> (FpgaBackend, Arc<Mutex<Model>>) {
        let (mut b, m) = connect();
        m.lock().unwrap().steps = 300;
        m.lock().unwrap().position[1] = 500;
        let l = launch(&b, 0, 300);
        b.start(vec![l], None, &Default::default(), 0).unwrap();
        assert!(events(&mut b, 1).is_empty(), "still moving");
        assert_eq!(b.count(1), 500, "an idle axis read while another moves");
        (b, m)
    }

    #[test]
    fn a_reset_marks_an_idle_axis_lost_and_takes_the_boards_count() {
        let (mut b, m) = moving_beside_a_resting_axis();
        m.lock().unwrap().power_cycle();
        let ev = events(&mut b, 2);
        let idle: Vec<&str> = ev
            .iter()
            .filter_map(|(i, e)| match e {
                PinEvent::Lost { why } if *i == 1 => Some(why.as_str()),
                _ => None,
            })
            .collect();
        assert!(
            matches!(idle[..], [why] if why.contains("was lost;")),
            "{ev:?}"
        );
        assert_eq!(b.count(1), 0, "the board's count after the reset");
    }

    /// A link failure part way through claiming a reset board (the token written, the
    /// setup's first reply lost) still tells the loss: the next polls find the board
    /// holding this host's token and would never see the reset.
    #[test]
    fn a_reset_is_told_even_when_the_claim_fails_part_way() {
        let (mut b, m) = moving_beside_a_resting_axis();
        {
            let mut m = m.lock().unwrap();
            m.power_cycle();
            // every reply to a Debounce write is lost: the claim's setup fails after
            // the Session write
            m.mute = Some(0x0D);
        }
        let ev = events(&mut b, 2);
        let lost: Vec<usize> = ev
            .iter()
            .filter(|(_, e)| matches!(e, PinEvent::Lost { .. }))
            .map(|(i, _)| *i)
            .collect();
        assert_eq!(lost, [0, 1], "{ev:?}");
        assert_ne!(m.lock().unwrap().session, 0, "the token was written");
    }

    /// A claim the link cut short is finished once the link is back: the reset board's
    /// registers, its ENABLE among them, are set up again, so no move runs on a driver
    /// the reset switched off while the host believes it on.
    #[test]
    fn a_claim_cut_short_is_finished_when_the_link_is_back() {
        let (mut b, m) = connect();
        // Y released, X on: the power-up value (0) and the default (both) differ from it
        b.set_enabled(1, false).unwrap();
        assert_eq!(m.lock().unwrap().enable, 1);
        {
            let mut m = m.lock().unwrap();
            m.power_cycle();
            // every reply to a Debounce write is lost: the claim's setup fails after
            // the Session write, before the Enable write
            m.mute = Some(0x0D);
        }
        events(&mut b, 1);
        {
            let m = m.lock().unwrap();
            assert_ne!(m.session, 0, "the token was written");
            assert_eq!(m.enable, 0, "the claim was cut before ENABLE");
        }
        m.lock().unwrap().mute = None;
        std::thread::sleep(super::super::spec::RECONNECT_PERIOD);
        events(&mut b, 2);
        assert_eq!(m.lock().unwrap().enable, 1, "ENABLE set again");
        m.lock().unwrap().steps = 300;
        let l = launch(&b, 0, 300);
        b.start(vec![l], None, &Default::default(), 3).unwrap();
        m.lock().unwrap().finish();
        events(&mut b, 4);
        assert_eq!(b.count(0), 300, "the move after the claim runs");
    }

    /// A count kept partly outside the register (adopted after a restart) is folded into
    /// the register once, at rest: later moves count from the register alone.
    #[test]
    fn an_offset_is_folded_in_once_at_rest() {
        use crate::store::LinkSession;
        const TOKEN: u32 = 0x5EED_0003;
        let mut model = Model::default();
        (model.session, model.busy, model.dir) = (TOKEN, 0b01, 0b01);
        (model.position, model.steps) = ([100, 0], 700);
        let m = Arc::new(Mutex::new(model));
        let port = m.clone();
        let open: Opener = Box::new(move || Ok(Box::new(ModelPort(port.clone())) as Box<dyn Port>));
        let before = LinkSession {
            token: TOKEN,
            offsets: vec![3600, 0],
            streamed: 0,
            armed: 0,
            folding: None,
            rolled: 0,
        };
        let mut b = FpgaBackend::with_opener_resuming("model".into(), open, 2, Some(before))
            .expect("the model answers");
        // as the board connects it to its store
        b.keep_session(Box::new(|_| Ok(())));
        assert_eq!(b.count(0), 3700, "the register plus the kept offset");
        m.lock().unwrap().finish();
        events(&mut b, 1);
        assert_eq!((b.count(0), m.lock().unwrap().position[0]), (4400, 4400));
        m.lock().unwrap().steps = 100;
        let l = launch(&b, 0, 100);
        b.start(vec![l], None, &Default::default(), 2).unwrap();
        m.lock().unwrap().finish();
        events(&mut b, 3);
        assert_eq!(b.count(0), 4500);
    }

    /// The whole board: a reset of an idle board leaves no axis trusted or homed.
    #[test]
    fn a_reset_board_untrusts_its_idle_axes() {
        use crate::store::{AxisRecord, LinkSession, Store};
        use crate::{Board, BoardConfig};
        const TOKEN: u32 = 0x5EED_0002;
        let dir = tempfile::tempdir().unwrap();
        let config = BoardConfig::parse(
            "[board]\nname = \"t\"\n[[axis]]\nname = \"X\"\n[[axis]]\nname = \"Y\"\n",
        )
        .unwrap();
        let store = Store::open(dir.path()).unwrap();
        for (name, position) in [("X", 100), ("Y", -7)] {
            let rec = AxisRecord {
                position,
                homed: true,
                trusted: true,
                moving: None,
                sim_position: 0,
                slack: 0,
            };
            store.put_axis(name, &rec).unwrap();
        }
        let kept = LinkSession {
            token: TOKEN,
            offsets: vec![0, 0],
            streamed: 0,
            armed: 0,
            folding: None,
            rolled: 0,
        };
        store.put_link_session(&kept).unwrap();
        let mut model = Model::default();
        (model.session, model.position) = (TOKEN, [100, -7]);
        let m = Arc::new(Mutex::new(model));
        let port = m.clone();
        let open: Opener = Box::new(move || Ok(Box::new(ModelPort(port.clone())) as Box<dyn Port>));
        let before = store.link_session().unwrap();
        let pins = FpgaBackend::with_opener_resuming("model".into(), open, 2, before).unwrap();
        let mut board = Board::open_with(&config, store, Box::new(pins)).unwrap();
        let names = ["X".to_string(), "Y".to_string()];
        let st = board.status(&names, 1).unwrap();
        assert!(st.iter().all(|a| a.trusted && a.homed), "{st:?}");
        assert_eq!((st[0].position, st[1].position), (100, -7));
        m.lock().unwrap().power_cycle();
        // an idle board is read every IDLE_POLL: wait for the reset to be seen
        let deadline = Instant::now() + Duration::from_secs(20);
        let mut now = 2;
        while !board
            .warnings()
            .iter()
            .any(|w| w.contains("reset or lost power"))
        {
            assert!(Instant::now() < deadline, "the reset was never seen");
            board.status(&names, now).unwrap();
            now += 1;
            std::thread::yield_now();
        }
        let st = board.status(&names, now).unwrap();
        assert!(st.iter().all(|a| !a.trusted && !a.homed), "{st:?}");
    }
}
