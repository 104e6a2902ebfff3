//! Plots of a trace: commanded and actual speed over time, and following error over time.
//! SVG or PNG by the file's extension.

use crate::error::SimError;
use crate::TraceRow;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::sync::OnceLock;

/// DejaVu Sans (fonts/LICENSE), built in so plots draw on a machine with no fonts installed.
const EMBEDDED_FONT: &[u8] = include_bytes!("../fonts/DejaVuSans.ttf");

/// Registers the sans-serif font plotters lays text out with (once per program): the
/// embedded DejaVu Sans, or the TrueType file named by `MULTISTEP_FONT`.
pub fn ensure_font() -> Result<(), String> {
    static FONT: OnceLock<Result<(), String>> = OnceLock::new();
    FONT.get_or_init(|| {
        let (bytes, origin): (&'static [u8], String) =
            match std::env::var_os("MULTISTEP_FONT").filter(|p| !p.is_empty()) {
                Some(path) => {
                    let path = std::path::PathBuf::from(path);
                    let bytes = std::fs::read(&path).map_err(|e| {
                        format!("MULTISTEP_FONT={}: cannot read it: {e}", path.display())
                    })?;
                    // plotters keeps fonts for the life of the program.
                    let bytes = Box::leak(bytes.into_boxed_slice());
                    (bytes, format!("MULTISTEP_FONT={}", path.display()))
                }
                None => (EMBEDDED_FONT, "the embedded DejaVu Sans".into()),
            };
        plotters::style::register_font("sans-serif", FontStyle::Normal, bytes)
            .map_err(|_| format!("{origin} is not a usable TrueType font"))
    })
    .clone()
}

/// Writes the two-panel plot of `rows` to `path` (.svg or .png).
pub fn plot_trace(path: &str, title: &str, rows: &[TraceRow]) -> Result<(), SimError> {
    let err = |msg: String| SimError::Plot {
        file: path.to_string(),
        msg,
    };
    if rows.len() < 2 {
        return Err(err("the trace has fewer than two samples".into()));
    }
    ensure_font().map_err(err)?;
    let size = (1000, 700);
    let lower = path.to_ascii_lowercase();
    if lower.ends_with(".svg") {
        draw(SVGBackend::new(path, size).into_drawing_area(), title, rows).map_err(err)
    } else if lower.ends_with(".png") {
        draw(
            BitMapBackend::new(path, size).into_drawing_area(),
            title,
            rows,
        )
        .map_err(err)
    } else {
        Err(err("the file name must end in .svg or .png".into()))
    }
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    title: &str,
    rows: &[TraceRow],
) -> Result<(), String> {
    let e = |x: &dyn std::fmt::Display| x.to_string();
    root.fill(&WHITE).map_err(|x| e(&x))?;
    let root = root.titled(title, ("sans-serif", 20)).map_err(|x| e(&x))?;
    let (top, bottom) = root.split_vertically(370);
    let t_end = rows.last().map_or(1.0, |r| r.t) * 1e3;
    let range = |f: &dyn Fn(&TraceRow) -> f64| {
        let (lo, hi) = rows
            .iter()
            .map(f)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(v), b.max(v))
            });
        let pad = ((hi - lo) * 0.05).max(1e-9);
        (lo - pad)..(hi + pad)
    };
    let speed = |r: &TraceRow| r.commanded_speed_deg_s.max(r.actual_speed_deg_s);
    let speed_lo = |r: &TraceRow| r.commanded_speed_deg_s.min(r.actual_speed_deg_s);
    let (s_lo, s_hi) = (range(&speed_lo).start, range(&speed).end);
    let mut c = ChartBuilder::on(&top)
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..t_end, s_lo..s_hi)
        .map_err(|x| e(&x))?;
    c.configure_mesh()
        .x_desc("time (ms)")
        .y_desc("speed (°/s)")
        .draw()
        .map_err(|x| e(&x))?;
    // At most ~2000 points a line: twice the plot's width in pixels keeps every feature.
    let stride = rows.len().div_ceil(2000).max(1);
    let line =
        |f: fn(&TraceRow) -> f64| rows.iter().step_by(stride).map(move |r| (r.t * 1e3, f(r)));
    c.draw_series(LineSeries::new(line(|r| r.commanded_speed_deg_s), &BLUE))
        .map_err(|x| e(&x))?
        .label("commanded")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE));
    c.draw_series(LineSeries::new(line(|r| r.actual_speed_deg_s), &RED))
        .map_err(|x| e(&x))?
        .label("actual")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED));
    c.configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(|x| e(&x))?;
    let mut c = ChartBuilder::on(&bottom)
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..t_end, range(&|r: &TraceRow| r.error_deg))
        .map_err(|x| e(&x))?;
    c.configure_mesh()
        .x_desc("time (ms)")
        .y_desc("following error θ* − θ (°)")
        .draw()
        .map_err(|x| e(&x))?;
    c.draw_series(LineSeries::new(line(|r| r.error_deg), &BLACK))
        .map_err(|x| e(&x))?;
    root.present().map_err(|x| e(&x))
}
