//! Snapshots of every board, and the server-sent-events stream that repeats them.

use multistep_controller::{AxisState, AxisStatus, Controller};
use serde::Serialize;
use std::io::Write;
use std::sync::Arc;
use std::time::Duration;

/// Period of updates while any axis moves or homes (20 Hz), and at rest.
pub const MOVING_PERIOD: Duration = Duration::from_millis(50);
pub const IDLE_PERIOD: Duration = Duration::from_millis(250);

#[derive(Serialize)]
pub struct BoardSnapshot {
    pub board: usize,
    pub name: String,
    pub tick: u64,
    pub clock_hz: f64,
    pub estop: bool,
    pub warnings: Vec<String>,
    pub axes: Vec<AxisStatus>,
}

#[derive(Serialize)]
pub struct Snapshot {
    pub boards: Vec<BoardSnapshot>,
    /// Some axis is moving or homing.
    pub busy: bool,
}

/// Every axis of every board, each board read under one lock so its axes agree in time.
pub fn snapshot(boards: &[Arc<Controller>]) -> Snapshot {
    let boards: Vec<BoardSnapshot> = boards
        .iter()
        .enumerate()
        .map(|(k, c)| {
            c.with_board(|b, now| BoardSnapshot {
                board: k,
                name: b.name().to_string(),
                tick: now,
                clock_hz: b.clock_hz(),
                estop: b.is_estopped(),
                warnings: b.warnings().to_vec(),
                axes: b.status(&[], now).unwrap_or_default(),
            })
        })
        .collect();
    let busy = boards
        .iter()
        .flat_map(|b| &b.axes)
        .any(|a| matches!(a.state, AxisState::Moving | AxisState::Homing));
    Snapshot { boards, busy }
}

/// Writes snapshots as SSE until the client goes away.
pub fn stream(boards: &[Arc<Controller>], out: &mut dyn Write) -> std::io::Result<()> {
    out.write_all(
        b"HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\nCache-Control: no-store\r\n\
          Connection: close\r\nX-Content-Type-Options: nosniff\r\n\r\nretry: 1000\n\n",
    )?;
    loop {
        let s = snapshot(boards);
        let json = serde_json::to_string(&s).map_err(std::io::Error::other)?;
        out.write_all(format!("data: {json}\n\n").as_bytes())?;
        out.flush()?;
        std::thread::sleep(if s.busy { MOVING_PERIOD } else { IDLE_PERIOD });
    }
}
