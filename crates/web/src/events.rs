//! Snapshots of every board, and the server-sent-events stream that repeats them.

use crate::boards::BoardLink;
use crate::snapshot::{BoardSnapshot, IDLE_PERIOD, MOVING_PERIOD};
use crate::streams::StreamSlot;
use multistep_controller::AxisState;
use serde::Serialize;
use std::io::Write;

#[derive(Serialize)]
pub struct Snapshot {
    pub boards: Vec<BoardSnapshot>,
    /// Some axis is moving or homing.
    pub busy: bool,
}

/// Every axis of every board, each board read at one moment so its axes agree in time.
pub fn snapshot(boards: &[BoardLink]) -> Snapshot {
    let boards: Vec<BoardSnapshot> = boards
        .iter()
        .enumerate()
        .map(|(k, b)| b.snapshot(k))
        .collect();
    let busy = boards.iter().flat_map(|b| &b.axes).any(|a| {
        matches!(
            a.state,
            AxisState::Moving | AxisState::Homing | AxisState::Tracking
        )
    });
    Snapshot { boards, busy }
}

/// Writes snapshots as SSE (the body; the server sent the head) until the client goes
/// away or `slot` is given to another stream.
pub fn stream(boards: &[BoardLink], slot: &StreamSlot, out: &mut dyn Write) -> std::io::Result<()> {
    out.write_all(b"retry: 1000\n\n")?;
    while !slot.is_closed() {
        let s = snapshot(boards);
        let json = serde_json::to_string(&s).map_err(std::io::Error::other)?;
        out.write_all(format!("data: {json}\n\n").as_bytes())?;
        out.flush()?;
        std::thread::sleep(if s.busy { MOVING_PERIOD } else { IDLE_PERIOD });
    }
    Ok(())
}
