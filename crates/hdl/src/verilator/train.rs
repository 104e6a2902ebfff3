//! The workload that trains the model's profile-guided build: a board at work, as the HIL
//! runs it. Every axis is enabled; axis 0 replays a streamed schedule and the others run
//! computed trapezoids, all started as one group. The host's request frames go on
//! `uart_rx` at the board's bit time (its replies are not read). GCC then lays out the
//! per-cycle code for the paths a moving board takes (docs/BENCHMARKS.md, "HIL speed").

use super::{Inputs, VerilatedBoard};
use crate::link::{
    core_addr, move_writes, requests, start_write, AxisReg, BoardReg, BulkWrite, Reg, RegWrite,
    Request, BULK_MAX,
};
use crate::{AxisMove, BoardTop, HdlError};
use multistep_core::int::{IntClock, IntProfile, IntSegment};
use multistep_core::stream::StreamEncoder;

/// Simulated time the moves run for (s): the training costs about this times the
/// instrumented model's 20 CPU s per simulated second.
const TRAIN_S: f64 = 0.05;
/// Part of the model cache key: a new workload rebuilds the models.
pub(super) const VERSION: &str = "train-4";
/// Steps of the streamed schedule (its code fits the smallest stream buffer, 256 bytes).
const STREAM_STEPS: u64 = 300;

fn link(e: crate::link::LinkError) -> HdlError {
    HdlError::Sim(format!("training frames: {e}"))
}

/// Runs the workload on `board`, the model of `top`.
pub(super) fn train(board: &mut VerilatedBoard, top: &BoardTop) -> Result<(), HdlError> {
    let p = &top.core;
    let axes = p.axes;
    let all = (1u32 << axes) - 1;
    let clock_hz = p.clock_hz as u64;
    let mut writes = vec![RegWrite {
        reg: Reg::Board(BoardReg::Enable),
        data: all,
    }];
    // a trapezoid of four equal times per axis, 12 000 to 24 000 steps/s
    let ticks = (p.clock_hz * TRAIN_S / 4.0) as u64;
    for a in 1..axes {
        let v = 12_000 + 4_000 * u64::from(a % 4);
        let q = (v as f64 * TRAIN_S / 4.0) as u64; // steps in a quarter at v
        let segs = [(0, q / 2), (v, q), (v, q), (v, q / 2)].map(|(v0, steps)| IntSegment {
            v0,
            ticks,
            steps,
        });
        let prof = IntProfile::segments(&segs, IntClock::hz(clock_hz))
            .map_err(|e| HdlError::Sim(format!("training move: {e}")))?;
        let m = AxisMove::from_profile(&prof, a % 2 == 0, p)?;
        writes.extend(move_writes(p, a, &m, 0).map_err(link)?);
    }
    // axis 0 streamed: a cruise at 10 000 steps/s whose periods wobble by a few ticks
    let w = p.widths()?;
    writes.extend([
        RegWrite {
            reg: Reg::Core(core_addr(&w, true, 0, 1)),
            data: 1 << 31,
        },
        RegWrite {
            reg: Reg::Axis(0, AxisReg::StreamSteps),
            data: STREAM_STEPS as u32,
        },
    ]);
    let mut code = Vec::new();
    let mut enc = StreamEncoder::new();
    let period = clock_hz / 10_000;
    let mut t = 0;
    for i in 0..STREAM_STEPS {
        t += period + [0, 3, 1, 7][i as usize % 4];
        enc.edge(t, &mut |b| code.push(b))
            .map_err(|e| HdlError::Sim(format!("training stream: {e}")))?;
    }
    enc.finish(&mut |b| code.push(b));

    let bit = (p.clock_hz / f64::from(top.baud)).round() as u64;
    let mut frames: Vec<Vec<u8>> = requests(&writes, 0)
        .iter()
        .map(|r| r.encode().to_vec())
        .collect();
    for (i, chunk) in code.chunks(BULK_MAX).enumerate() {
        let bulk = BulkWrite {
            seq: i as u8,
            addr: Reg::Axis(0, AxisReg::StreamData).addr(),
            data: chunk.to_vec(),
        };
        frames.push(bulk.encode().map_err(link)?);
    }
    frames.push(requests(&[start_write(all)], 0)[0].encode().to_vec());
    let mut pins = Inputs::default();
    let mut send = |board: &mut VerilatedBoard, frame: &[u8]| {
        for &byte in frame {
            // 8N1, low bit first
            let bits = [false]
                .into_iter()
                .chain((0..8).map(|i| byte >> i & 1 == 1))
                .chain([true]);
            for level in bits {
                pins.uart_rx = level;
                board.set_inputs(&pins);
                board.run(bit, 0);
            }
        }
        // the frame's end (a gap of four characters) and the board's reply
        board.run(bit * 200, 0);
    };
    for f in frames {
        send(board, &f);
    }
    // the moves run while the host polls `Busy`, as it does
    let polls = 5;
    for i in 0..polls {
        send(
            board,
            &Request::read(i, Reg::Board(BoardReg::Busy)).encode(),
        );
        board.run((p.clock_hz * TRAIN_S / f64::from(polls)) as u64, 0);
    }
    Ok(())
}
