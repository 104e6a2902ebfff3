//! The trace of a simulated move as CSV.

use crate::error::SimError;
use crate::TraceRow;
use std::io::Write;

pub fn write_csv(path: &str, rows: &[TraceRow]) -> Result<(), SimError> {
    let io = |source| SimError::Io {
        file: path.to_string(),
        source,
    };
    let f = std::fs::File::create(path).map_err(io)?;
    let mut w = std::io::BufWriter::new(f);
    writeln!(
        w,
        "t_s,commanded_deg,actual_deg,commanded_speed_deg_s,actual_speed_deg_s,error_deg,ia_a,ib_a"
    )
    .map_err(io)?;
    for r in rows {
        writeln!(
            w,
            "{:.7},{:.6},{:.6},{:.3},{:.3},{:.6},{:.5},{:.5}",
            r.t,
            r.commanded_deg,
            r.actual_deg,
            r.commanded_speed_deg_s,
            r.actual_speed_deg_s,
            r.error_deg,
            r.ia,
            r.ib
        )
        .map_err(io)?;
    }
    w.flush().map_err(io)
}
