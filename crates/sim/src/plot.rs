//! Plots of a trace: commanded and actual speed over time, and following error over time.
//! SVG or PNG by the file's extension. [`tick_label`] formats the numbers on every axis.

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

/// A tick label: the shortest form of the value, so whole numbers have no ".0" ("9000"),
/// and zero is "0", never "-0". Pass it to plotters' `x_label_formatter`/`y_label_formatter`.
pub fn tick_label(v: &f64) -> String {
    if !v.is_finite() {
        return v.to_string();
    }
    // 12 significant digits drop the noise of tick arithmetic (0.30000000000000004 → 0.3).
    let v: f64 = format!("{v:.11e}").parse().unwrap_or(*v);
    if v == 0.0 {
        "0".into()
    } else {
        v.to_string()
    }
}

/// The unit the following-error panel is drawn in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ErrorUnit {
    /// Degrees of shaft angle, as the trace has them.
    Degrees,
    /// Microsteps of the driver: `deg` degrees each (`Motor::microstep_angle` in degrees).
    Microsteps { deg: f64 },
}

impl ErrorUnit {
    fn per_deg(self) -> f64 {
        match self {
            ErrorUnit::Degrees => 1.0,
            ErrorUnit::Microsteps { deg } => 1.0 / deg,
        }
    }

    fn axis_label(self) -> &'static str {
        match self {
            ErrorUnit::Degrees => "following error θ* − θ (°)",
            ErrorUnit::Microsteps { .. } => "following error θ* − θ (microsteps)",
        }
    }
}

/// Writes the two-panel plot of `rows` to `path` (.svg or .png), the following error in `unit`.
pub fn plot_trace(
    path: &str,
    title: &str,
    rows: &[TraceRow],
    unit: ErrorUnit,
) -> Result<(), SimError> {
    let err = |msg: String| SimError::Plot {
        file: path.to_string(),
        msg,
    };
    if rows.len() < 2 {
        return Err(err("the trace has fewer than two samples".into()));
    }
    if let ErrorUnit::Microsteps { deg } = unit {
        if !(deg.is_finite() && deg > 0.0) {
            return Err(err(format!("a microstep of {deg}° cannot be a unit")));
        }
    }
    ensure_font().map_err(err)?;
    let size = (1000, 700);
    let lower = path.to_ascii_lowercase();
    if lower.ends_with(".svg") {
        let area = SVGBackend::new(path, size).into_drawing_area();
        draw(area, title, rows, unit).map_err(err)
    } else if lower.ends_with(".png") {
        let area = BitMapBackend::new(path, size).into_drawing_area();
        draw(area, title, rows, unit).map_err(err)
    } else {
        Err(err("the file name must end in .svg or .png".into()))
    }
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    title: &str,
    rows: &[TraceRow],
    unit: ErrorUnit,
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
        .x_label_formatter(&tick_label)
        .y_label_formatter(&tick_label)
        .x_desc("time (ms)")
        .y_desc("speed (°/s)")
        .draw()
        .map_err(|x| e(&x))?;
    // At most ~2000 points a line: twice the plot's width in pixels keeps every feature.
    let stride = rows.len().div_ceil(2000).max(1);
    let line = |f: &dyn Fn(&TraceRow) -> f64| {
        rows.iter()
            .step_by(stride)
            .map(|r| (r.t * 1e3, f(r)))
            .collect::<Vec<_>>()
    };
    c.draw_series(LineSeries::new(line(&|r| r.commanded_speed_deg_s), &BLUE))
        .map_err(|x| e(&x))?
        .label("commanded")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE));
    c.draw_series(LineSeries::new(line(&|r| r.actual_speed_deg_s), &RED))
        .map_err(|x| e(&x))?
        .label("actual")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED));
    c.configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(|x| e(&x))?;
    let scale = unit.per_deg();
    let error = |r: &TraceRow| r.error_deg * scale;
    let mut c = ChartBuilder::on(&bottom)
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..t_end, range(&error))
        .map_err(|x| e(&x))?;
    c.configure_mesh()
        .x_label_formatter(&tick_label)
        .y_label_formatter(&tick_label)
        .x_desc("time (ms)")
        .y_desc(unit.axis_label())
        .draw()
        .map_err(|x| e(&x))?;
    c.draw_series(LineSeries::new(line(&error), &BLACK))
        .map_err(|x| e(&x))?;
    root.present().map_err(|x| e(&x))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_are_short_and_never_negative_zero() {
        assert_eq!(tick_label(&9000.0), "9000");
        assert_eq!(tick_label(&0.0), "0");
        assert_eq!(tick_label(&-0.0), "0");
        assert_eq!(tick_label(&-1.5), "-1.5");
        assert_eq!(tick_label(&0.30000000000000004), "0.3");
        assert_eq!(tick_label(&-0.2), "-0.2");
        assert_eq!(tick_label(&12000.0), "12000");
        assert_eq!(tick_label(&0.0025), "0.0025");
        assert_eq!(tick_label(&2.5e-7), "0.00000025");
    }

    /// The text elements of an SVG, trimmed.
    fn texts(svg: &str) -> Vec<String> {
        svg.split("<text")
            .skip(1)
            .filter_map(|t| {
                let body = &t[t.find('>')? + 1..t.find("</text>")?];
                Some(body.trim().to_string())
            })
            .collect()
    }

    fn trace() -> Vec<TraceRow> {
        // 5 ms; error swings through zero, from −0.3° to +0.9°; speed up to 9000 °/s
        (0..=500)
            .map(|i| {
                let t = i as f64 * 1e-5;
                TraceRow {
                    t,
                    commanded_deg: 0.0,
                    actual_deg: 0.0,
                    commanded_speed_deg_s: 9000.0 * (t / 0.005),
                    actual_speed_deg_s: 9000.0 * (t / 0.005),
                    error_deg: 0.3 + 0.6 * (t * 2000.0).sin(),
                    ia: 0.0,
                    ib: 0.0,
                }
            })
            .collect()
    }

    fn plot_texts(unit: ErrorUnit) -> Vec<String> {
        let path = std::env::temp_dir().join(format!(
            "multistep-plot-{}-{:?}.svg",
            std::process::id(),
            unit.per_deg()
        ));
        let path = path.to_str().unwrap();
        plot_trace(path, "a move", &trace(), unit).unwrap();
        let svg = std::fs::read_to_string(path).unwrap();
        std::fs::remove_file(path).ok();
        texts(&svg)
    }

    #[test]
    fn plot_ticks_are_whole_numbers_without_decimals_and_no_negative_zero() {
        let t = plot_texts(ErrorUnit::Degrees);
        assert!(t.iter().any(|x| x == "9000" || x == "8000"), "{t:?}");
        assert!(t.iter().any(|x| x == "0"), "{t:?}");
        for x in &t {
            assert!(!x.ends_with(".0"), "tick {x:?} in {t:?}");
            if x.parse::<f64>() == Ok(0.0) {
                assert_eq!(x, "0", "{t:?}");
            }
        }
        assert!(t.iter().any(|x| x == "following error θ* − θ (°)"));
    }

    #[test]
    fn error_panel_draws_in_the_unit_it_names() {
        // 1/256 of 1.8°: −0.3…+0.9° is −43…+128 microsteps; no other axis has a tick at 100
        let t = plot_texts(ErrorUnit::Microsteps { deg: 1.8 / 256.0 });
        assert!(
            t.iter().any(|x| x == "following error θ* − θ (microsteps)"),
            "{t:?}"
        );
        assert!(!t.iter().any(|x| x.contains("(°)") && x.contains("error")));
        assert!(t.iter().any(|x| x == "100"), "{t:?}");
        assert!(!plot_texts(ErrorUnit::Degrees).iter().any(|x| x == "100"));
    }

    #[test]
    fn a_bad_unit_is_refused() {
        let r = plot_trace("x.svg", "t", &trace(), ErrorUnit::Microsteps { deg: 0.0 });
        assert!(r.is_err());
    }
}
