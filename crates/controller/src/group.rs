//! A group on the axes of several boards (docs/HDL.md "Cross-board start"): each board's
//! share is armed (`arm …`), every board is polled until its share is ready, the first
//! board fires the shared SYNC line, and each board's latched count is read.
//!
//! The group fails whole: if an arm, a wait or the fire fails on any board, every share
//! sent (the failing one too: its arm may have taken) is stopped — a stop disarms — before
//! the error is returned, and a share that could not be stopped is named in it. Such a
//! share does not outlive its group for long: its service disarms it when its link comes
//! back and once it has waited [`crate::backend::fpga::ARM_LIFETIME`].

use std::time::{Duration, Instant};

/// Why a line got no answer, and whether its board certainly did nothing.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SendError {
    pub text: String,
    /// The service refused the line itself (a bad word, a busy axis, a board without a
    /// SYNC line): nothing was armed, so nothing needs stopping — stopping would halt
    /// whatever that axis is doing. False when the link failed and the line may have
    /// taken effect.
    pub nothing_applied: bool,
}

impl SendError {
    /// A failure after which the line may have taken effect.
    pub fn uncertain(text: impl Into<String>) -> SendError {
        SendError {
            text: text.into(),
            nothing_applied: false,
        }
    }
}

impl From<SendError> for String {
    fn from(e: SendError) -> String {
        e.text
    }
}

/// The boards of a group, reached by their protocol lines.
pub trait GroupBoards {
    /// The board's name, for messages.
    fn name(&self, board: usize) -> String;
    /// Sends one protocol line; the answer's lines, or why there is none.
    fn send(&mut self, board: usize, line: &str) -> Result<Vec<String>, SendError>;
    /// Waits a little before polling again.
    fn pause(&mut self) {
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// One board's share of the group.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Share {
    pub board: usize,
    /// Its axes, stopped if the group fails.
    pub axes: Vec<String>,
    /// The `arm …` line.
    pub line: String,
}

/// How long every board's share may take to be ready.
pub const ARM_PATIENCE: Duration = Duration::from_secs(10);

/// A group that started: each board's answer to its arm (`BOARD:LINE`), and each board's
/// count at the SYNC fall with its offset to the first board's clock (ticks).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Started {
    pub answers: Vec<String>,
    pub ticks: Vec<(usize, u32, i64)>,
}

/// Why a group failed, and the shares that could not be disarmed.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{why}; {}", disarmed_text(.not_disarmed))]
pub struct GroupError {
    pub why: String,
    /// (board, why its stop failed) for every share left armed.
    pub not_disarmed: Vec<(String, String)>,
}

fn disarmed_text(not: &[(String, String)]) -> String {
    if not.is_empty() {
        return "every board's share was disarmed".into();
    }
    let each: Vec<String> = not.iter().map(|(b, e)| format!("board {b}: {e}")).collect();
    format!(
        "NOT disarmed on {} — its service disarms it once its link answers again, or {} s \
         after it was armed",
        each.join("; "),
        crate::backend::fpga::ARM_LIFETIME.as_secs()
    )
}

/// One board's `synctick` answer: (latched count, armed, ready, late).
fn sync_state(b: &mut dyn GroupBoards, i: usize) -> Result<(u32, bool, bool, bool), String> {
    let lines = b.send(i, "synctick")?;
    let line = lines.first().map_or("", |s| s.as_str());
    let mut st = (None, false, false, false);
    for w in line.split_whitespace() {
        match w.split_once('=') {
            Some(("synctick", v)) => st.0 = v.parse().ok(),
            Some(("armed", v)) => st.1 = v == "1",
            Some(("ready", v)) => st.2 = v == "1",
            Some(("late", v)) => st.3 = v == "1",
            _ => {}
        }
    }
    let tick =
        st.0.ok_or_else(|| format!("board {}: synctick answered '{line}'", b.name(i)))?;
    Ok((tick, st.1, st.2, st.3))
}

/// Arms every share, waits until all are ready (at most `patience`), fires from the first
/// board and reads each board's count at the fall. On any failure every share sent is
/// stopped before the error returns.
pub fn start_across(
    boards: &mut dyn GroupBoards,
    shares: &[Share],
    patience: Duration,
) -> Result<Started, GroupError> {
    let mut sent = 0;
    let mut answers = Vec::new();
    let r = run(boards, shares, patience, &mut sent, &mut answers);
    match r {
        Ok(ticks) => {
            let offsets = multistep_link::sync_offsets(&ticks);
            let ticks = shares
                .iter()
                .zip(ticks.iter().zip(offsets))
                .map(|(s, (&t, o))| (s.board, t, o))
                .collect();
            Ok(Started { answers, ticks })
        }
        Err(why) => {
            let mut not_disarmed = Vec::new();
            for s in &shares[..sent] {
                for ax in &s.axes {
                    if let Err(e) = boards.send(s.board, &format!("stop {ax}")) {
                        not_disarmed.push((boards.name(s.board), e.text));
                        break;
                    }
                }
            }
            Err(GroupError { why, not_disarmed })
        }
    }
}

fn run(
    boards: &mut dyn GroupBoards,
    shares: &[Share],
    patience: Duration,
    sent: &mut usize,
    answers: &mut Vec<String>,
) -> Result<Vec<u32>, String> {
    for s in shares {
        *sent += 1;
        let answer = boards.send(s.board, &s.line).map_err(|e| {
            if e.nothing_applied {
                *sent -= 1;
            }
            e.text
        })?;
        let name = boards.name(s.board);
        answers.extend(answer.into_iter().map(|l| format!("{name}:{l}")));
    }
    let deadline = Instant::now() + patience;
    for s in shares {
        loop {
            let (_, armed, ready, _) = sync_state(boards, s.board)?;
            if !armed {
                return Err(format!(
                    "board {}: its share of the group is no longer armed",
                    boards.name(s.board)
                ));
            }
            if ready {
                break;
            }
            if Instant::now() > deadline {
                return Err(format!(
                    "board {}: the armed group is not ready",
                    boards.name(s.board)
                ));
            }
            boards.pause();
        }
    }
    boards.send(shares[0].board, "fire")?;
    let mut ticks = Vec::new();
    for s in shares {
        let (tick, armed, _, late) = sync_state(boards, s.board)?;
        if armed || late {
            return Err(format!(
                "board {}: its group did not start on the SYNC fall",
                boards.name(s.board)
            ));
        }
        ticks.push(tick);
    }
    Ok(ticks)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Boards that answer as their services would, one armed flag each; a cut link
    /// answers nothing. The SYNC line is shared: `fire` starts every armed board.
    #[derive(Default)]
    struct Fake {
        armed: Vec<bool>,
        cut: Vec<bool>,
        /// Board `i` refuses every arm itself (no SYNC line).
        no_sync: Vec<bool>,
        /// `cut` board `i` once it has been sent `n` more lines.
        cut_after: Option<(usize, usize)>,
        starts: Vec<usize>,
        sent: Vec<(usize, String)>,
    }

    impl Fake {
        fn new(n: usize) -> Fake {
            Fake {
                armed: vec![false; n],
                cut: vec![false; n],
                no_sync: vec![false; n],
                starts: vec![0; n],
                ..Fake::default()
            }
        }
    }

    impl GroupBoards for Fake {
        fn name(&self, board: usize) -> String {
            ["a", "b"][board].into()
        }
        fn send(&mut self, i: usize, line: &str) -> Result<Vec<String>, SendError> {
            if let Some((b, n)) = self.cut_after {
                if b == i {
                    if n == 0 {
                        self.cut[i] = true;
                    }
                    self.cut_after = Some((b, n.saturating_sub(1)));
                }
            }
            if self.cut[i] {
                return Err(SendError::uncertain("link down"));
            }
            if self.no_sync[i] && line.starts_with("arm") {
                return Err(SendError {
                    text: "error:8 this board has no SYNC line".into(),
                    nothing_applied: true,
                });
            }
            self.sent.push((i, line.to_string()));
            let word = line.split_whitespace().next().unwrap_or("");
            match word {
                "arm" => self.armed[i] = true,
                "stop" => self.armed[i] = false,
                "fire" => {
                    for b in 0..self.armed.len() {
                        if std::mem::take(&mut self.armed[b]) {
                            self.starts[b] += 1;
                        }
                    }
                }
                _ => {}
            }
            let armed = u8::from(self.armed[i]);
            Ok(vec![format!(
                "synctick=7 armed={armed} ready={armed} late=0 line=1"
            )])
        }
        fn pause(&mut self) {}
    }

    fn share(board: usize, axis: &str) -> Share {
        Share {
            board,
            axes: vec![axis.into()],
            line: format!("arm move {axis}=100"),
        }
    }

    #[test]
    fn a_group_across_two_boards_fires_once_from_the_first() {
        let mut f = Fake::new(2);
        let s = start_across(&mut f, &[share(0, "X"), share(1, "Y")], ARM_PATIENCE).unwrap();
        assert_eq!(f.starts, [1, 1]);
        assert_eq!(s.ticks, [(0, 7, 0), (1, 7, 0)]);
        assert_eq!(f.sent.iter().filter(|(_, l)| l == "fire").count(), 1);
    }

    /// Both shares armed, b's link cut before the group is fired, so b's stop fails too:
    /// the error says b's share was not disarmed; a's share was.
    #[test]
    fn a_failing_board_disarms_the_group_everywhere_and_names_a_stop_that_failed() {
        let mut f = Fake::new(2);
        // b answers its arm, then nothing
        f.cut_after = Some((1, 1));
        let e = start_across(&mut f, &[share(0, "X"), share(1, "Y")], ARM_PATIENCE)
            .expect_err("b's link is cut");
        assert!(e.why.contains("link down"), "{e}");
        assert_eq!(e.not_disarmed, [("b".to_string(), "link down".to_string())]);
        assert!(e.to_string().contains("NOT disarmed on board b"), "{e}");
        assert!(!f.armed[0], "a disarmed");
        assert!(f.sent.contains(&(0, "stop X".into())));
        assert_eq!(f.starts, [0, 0], "nothing fired");
    }

    #[test]
    fn a_refused_arm_disarms_the_shares_before_it_and_its_own() {
        let mut f = Fake::new(2);
        f.cut[1] = true;
        let e = start_across(&mut f, &[share(0, "X"), share(1, "Y")], ARM_PATIENCE)
            .expect_err("b is down");
        assert!(!f.armed[0]);
        assert_eq!(e.not_disarmed.len(), 1, "b's own stop was tried: {e}");
        assert_eq!(f.starts, [0, 0]);
    }

    /// A share the service refused outright armed nothing: its axis is not stopped, so a
    /// move it was already making goes on; the shares armed before it are stopped.
    #[test]
    fn a_share_refused_by_its_service_is_not_stopped() {
        let mut f = Fake::new(2);
        f.no_sync[1] = true;
        let e = start_across(&mut f, &[share(0, "X"), share(1, "Y")], ARM_PATIENCE)
            .expect_err("b has no SYNC line");
        assert!(e.why.contains("no SYNC line"), "{e}");
        assert!(f.sent.contains(&(0, "stop X".into())), "{:?}", f.sent);
        assert!(!f.sent.contains(&(1, "stop Y".into())), "{:?}", f.sent);
        assert!(e.not_disarmed.is_empty());
    }
}
