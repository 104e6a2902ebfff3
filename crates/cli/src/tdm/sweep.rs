//! `multistep tdm --sweep`: k_max (the most axes one calculator serves with no underrun)
//! against the maximum step rate, next to seed 000's eq. (12), as a table and an SVG plot.
//!
//! Every axis runs the same seed-000-shaped trapezoid, all started together: the worst
//! phase alignment, since every axis needs its periods at the same ticks.

use super::config::ConfigFile;
use super::{PolicyArg, TdmArgs, TdmFormat};
use anyhow::{bail, Context};
use clap::Args;
use multistep_core::tdm::{k_max, rate_move, Axis, KMax, Policy, TdmConfig, MAX_AXES};
use plotters::prelude::*;
use serde::Serialize;
use std::io::Write;
use std::path::PathBuf;

/// The most rates one sweep takes (a plot has no use for more points).
const MAX_POINTS: usize = 1000;

#[derive(Args, Debug)]
pub struct SweepArgs {
    /// Sweep: maximum step rates MIN:MAX:POINTS (steps/s; 1 to 1000 points)
    #[arg(long, value_name = "MIN:MAX:N", default_value = "10000:200000:20")]
    pub rates: String,
    /// Sweep and --k-max: most axes to try (up to 64)
    #[arg(long, value_name = "K", default_value_t = MAX_AXES)]
    pub max_axes: usize,
    /// Sweep: FIFO depths to compare
    #[arg(
        long,
        value_name = "D,..",
        value_delimiter = ',',
        default_value = "1,4"
    )]
    pub fifo_depths: Vec<usize>,
    /// Sweep: accel, cruise and decel time of each axis's trapezoid (s)
    #[arg(long, value_name = "TA:TB:TC", default_value = "0.02:0.01:0.02")]
    pub move_times: String,
    /// Sweep: SVG plot of k_max against the rate
    #[arg(long, value_name = "FILE", default_value = "tdm-sweep.svg")]
    pub plot: PathBuf,
}

#[derive(Serialize, Debug)]
struct Series {
    policy: &'static str,
    fifo_depth: usize,
    k_max: usize,
    /// k_max is the most axes tried; the real bound may be higher.
    capped: bool,
}

#[derive(Serialize, Debug)]
struct Row {
    rate_steps_per_s: f64,
    min_period_ticks: u64,
    k_eq12: u64,
    series: Vec<Series>,
}

#[derive(Serialize, Debug)]
struct SweepOut {
    clock_hz: f64,
    interval_cycles: u64,
    latency_cycles: u64,
    move_times_s: [f64; 3],
    rows: Vec<Row>,
}

fn numbers<const N: usize>(s: &str, what: &str) -> anyhow::Result<[f64; N]> {
    let v: Vec<f64> = s
        .split(':')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("{what} '{s}'"))?;
    v.try_into()
        .map_err(|_| anyhow::anyhow!("{what} '{s}' needs {N} numbers separated by ':'"))
}

pub fn run(args: &TdmArgs) -> anyhow::Result<()> {
    let sa = &args.sweep_args;
    let [lo, hi, n] = numbers::<3>(&sa.rates, "--rates")?;
    let times = numbers::<3>(&sa.move_times, "--move-times")?;
    if !(lo > 0.0 && hi >= lo && (1.0..=MAX_POINTS as f64).contains(&n) && n.fract() == 0.0) {
        bail!("--rates MIN:MAX:N needs 0 < MIN <= MAX and a whole N from 1 to {MAX_POINTS}");
    }
    if sa.max_axes == 0 || sa.max_axes > MAX_AXES {
        bail!("--max-axes must be 1 to {MAX_AXES}");
    }
    let file = match &args.config {
        Some(p) => ConfigFile::load(p)?,
        None => ConfigFile::default(),
    };
    let base = file.board(None)?;
    let policies: Vec<Policy> = match args.policy {
        Some(p) => vec![Policy::from(p)],
        None => vec![
            PolicyArg::RoundRobin.into(),
            PolicyArg::EarliestDeadline.into(),
        ],
    };
    let n = n as usize;
    let rate = |i: usize| {
        if n == 1 {
            lo
        } else {
            lo + (hi - lo) * i as f64 / (n - 1) as f64
        }
    };
    // every rate's k_max search, once per FIFO depth and policy
    let runs = (sa.fifo_depths.len() * policies.len()) as u128;
    let mut edges: u128 = 0;
    for i in 0..n {
        let steps = rate_move(rate(i), times[0], times[1], times[2])?.steps();
        edges += runs * super::k_max_edges(&[steps], sa.max_axes);
        super::check_edges(
            edges,
            "lower the rates, shorten --move-times, or give fewer points, --fifo-depths or --max-axes",
        )?;
    }
    let mut rows = Vec::with_capacity(n);
    for i in 0..n {
        let rate = rate(i);
        let mv = rate_move(rate, times[0], times[1], times[2])?;
        let mut storage: Vec<Axis> = (0..sa.max_axes)
            .map(|_| Axis::new(mv.clone(), base.clock_hz))
            .collect::<Result<_, _>>()?;
        let mut row = None::<Row>;
        let mut series = Vec::new();
        for &fifo_depth in &sa.fifo_depths {
            for &policy in &policies {
                let cfg = TdmConfig {
                    fifo_depth,
                    policy,
                    ..base
                };
                let km: KMax = k_max(&cfg, std::slice::from_ref(&mv), &mut storage)?;
                row.get_or_insert(Row {
                    rate_steps_per_s: rate,
                    min_period_ticks: km.min_period_ticks,
                    k_eq12: km.k_eq12,
                    series: Vec::new(),
                });
                series.push(Series {
                    policy: policy.name(),
                    fifo_depth,
                    k_max: km.k_max,
                    capped: km.capped,
                });
            }
        }
        let mut row = row.context("--fifo-depths is empty")?;
        row.series = series;
        rows.push(row);
    }
    let out = SweepOut {
        clock_hz: base.clock_hz,
        interval_cycles: base.latencies.interval(),
        latency_cycles: base.latencies.latency(),
        move_times_s: times,
        rows,
    };
    plot(&out, &sa.plot)?;
    let mut w = std::io::stdout().lock();
    match args.format {
        TdmFormat::Json => writeln!(w, "{}", serde_json::to_string_pretty(&out)?)?,
        TdmFormat::Table => print_table(&mut w, &out)?,
    }
    w.flush()?;
    eprintln!("plot written to {}", sa.plot.display());
    Ok(())
}

fn series_name(s: &Series) -> String {
    format!("{} D={}", s.policy, s.fifo_depth)
}

fn print_table(w: &mut impl Write, out: &SweepOut) -> anyhow::Result<()> {
    writeln!(
        w,
        "clock {} Hz, t_calc {} cycles (latency {}), trapezoid {:?} s, all axes started together",
        out.clock_hz, out.interval_cycles, out.latency_cycles, out.move_times_s
    )?;
    write!(w, "{:>12} {:>8} {:>6}", "rate", "Δt_min", "eq.12")?;
    if let Some(r) = out.rows.first() {
        for s in &r.series {
            write!(w, " {:>22}", series_name(s))?;
        }
    }
    writeln!(w)?;
    for r in &out.rows {
        write!(
            w,
            "{:>12.0} {:>8} {:>6}",
            r.rate_steps_per_s, r.min_period_ticks, r.k_eq12
        )?;
        for s in &r.series {
            let k = if s.capped {
                format!(">={}", s.k_max)
            } else {
                s.k_max.to_string()
            };
            write!(w, " {:>22}", k)?;
        }
        writeln!(w)?;
    }
    Ok(())
}

/// What the plot draws, in its own units: rates in k steps/s, eq. (12) as computed (never cut
/// to the axes tried), one line per series, and the y range that holds all of them.
struct PlotData {
    eq12: Vec<(f64, f64)>,
    series: Vec<(String, Vec<(f64, f64)>)>,
    /// For each series, the line drawn before it that it equals at every rate.
    same_as: Vec<Option<String>>,
    /// The most axes tried, when some series reached it (its k_max may be higher).
    cap: Option<f64>,
    x: std::ops::Range<f64>,
    y: std::ops::Range<f64>,
}

const EQ12_LABEL: &str = "seed 000 eq. (12): Δt_min / t_calc";

fn plot_data(out: &SweepOut) -> PlotData {
    let x = |r: &Row| r.rate_steps_per_s / 1e3;
    let eq12: Vec<(f64, f64)> = out.rows.iter().map(|r| (x(r), r.k_eq12 as f64)).collect();
    let count = out.rows.first().map_or(0, |r| r.series.len());
    let series: Vec<(String, Vec<(f64, f64)>)> = (0..count)
        .map(|i| {
            let pts = out.rows.iter().map(|r| (x(r), r.series[i].k_max as f64));
            (series_name(&out.rows[0].series[i]), pts.collect())
        })
        .collect();
    let same_as = (0..series.len())
        .map(|i| {
            let earlier = std::iter::once(("eq. (12)", &eq12))
                .chain(series[..i].iter().map(|(n, p)| (n.as_str(), p)));
            earlier
                .filter(|(_, pts)| **pts == series[i].1)
                .map(|(name, _)| name.to_string())
                .next()
        })
        .collect();
    let cap = out
        .rows
        .iter()
        .flat_map(|r| &r.series)
        .find(|s| s.capped)
        .map(|s| s.k_max as f64);
    let values = eq12.iter().chain(series.iter().flat_map(|(_, p)| p));
    let (x_max, y_max) = values.fold((0.0, 1.0), |(a, b), &(x, y)| {
        (f64::max(a, x), f64::max(b, y))
    });
    PlotData {
        eq12,
        series,
        same_as,
        cap,
        x: 0.0..x_max * 1.02,
        // headroom above the highest point, for its marker
        y: 0.0..y_max * 1.08 + 1.0,
    }
}

/// How series `i` is told apart from the others when their lines coincide: each is drawn
/// narrower than the one before it, with its own dash pattern and a smaller marker of its own
/// shape, so coinciding lines show as nested stripes and nested markers.
#[derive(Clone, Copy)]
struct Look {
    color: RGBColor,
    width: u32,
    /// dash and gap (pixels), or a solid line
    dash: Option<(u32, u32)>,
    /// the marker's shape (see [`marker`]), or none
    shape: Option<usize>,
}

const COLORS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
];

fn look(i: usize) -> Look {
    let (width, dash) = [(6, None), (4, Some((12, 6))), (2, Some((5, 4))), (1, None)][i % 4];
    Look {
        color: COLORS[i % COLORS.len()],
        width,
        dash,
        shape: Some(i % 4),
    }
}

/// Series `shape`'s marker around (0, 0), `scale` times its size in the plot: a hollow
/// circle, square, triangle, then a dot, each fitting inside the one before. A circle's radius
/// and whether it is filled, and a path: plotters draws a circle of radius 0 as nothing.
fn marker(shape: Option<usize>, scale: f64) -> (i32, bool, Vec<(i32, i32)>) {
    let polygon = |r: f64, n: usize, turn: f64| -> Vec<(i32, i32)> {
        (0..=n)
            .map(|k| {
                let a = std::f64::consts::TAU * (k as f64 / n as f64 + turn);
                let at = |v: f64| (scale * r * v).round() as i32;
                (at(a.cos()), at(a.sin()))
            })
            .collect()
    };
    let circle = |r: f64| {
        (
            ((scale * r).round() as i32).max(1),
            shape == Some(3),
            Vec::new(),
        )
    };
    match shape {
        None => (0, false, Vec::new()),
        Some(0) => circle(11.0),
        Some(1) => (0, false, polygon(7.0 * std::f64::consts::SQRT_2, 4, 0.125)),
        Some(2) => (0, false, polygon(5.5, 3, -0.25)),
        Some(_) => circle(2.5),
    }
}

fn plot(out: &SweepOut, path: &PathBuf) -> anyhow::Result<()> {
    let d = plot_data(out);
    multistep_sim::plot::ensure_font().map_err(anyhow::Error::msg)?;
    let tick = multistep_sim::plot::tick_label;
    let root = SVGBackend::new(path, (900, 560)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!(
                "axes served by one calculator (t_calc {} cycles, latency {})",
                out.interval_cycles, out.latency_cycles
            ),
            ("sans-serif", 20),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(d.x.clone(), d.y.clone())?;
    chart
        .configure_mesh()
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .x_desc("maximum step rate (k steps/s)")
        .y_desc("axes with no underrun")
        .draw()?;
    // a wide grey band, so the series drawn over it show whether they follow it
    let band = BLACK.mix(0.2).stroke_width(14);
    chart
        .draw_series(LineSeries::new(d.eq12.clone(), band))?
        .label(EQ12_LABEL)
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 30, y)], band));
    let mut lines = Vec::new();
    if let Some(cap) = d.cap {
        let dotted = Look {
            color: RGBColor(90, 90, 90),
            width: 1,
            dash: Some((2, 4)),
            shape: None,
        };
        let label = format!("{cap} axes, the most tried: k_max is at least this");
        lines.push((label, vec![(d.x.start, cap), (d.x.end, cap)], dotted));
    }
    for (i, ((name, pts), same)) in d.series.iter().zip(&d.same_as).enumerate() {
        let label = match same {
            Some(other) => format!("{name} (same as {other})"),
            None => name.clone(),
        };
        lines.push((label, pts.clone(), look(i)));
    }
    for (label, pts, l) in lines {
        let style = l.color.stroke_width(l.width);
        let anno = match l.dash {
            Some((on, off)) => {
                chart.draw_series(DashedLineSeries::new(pts.clone(), on, off, style))?
            }
            None => chart.draw_series(LineSeries::new(pts.clone(), style))?,
        };
        // the marker as two elements relative to its point: a circle and a path
        let marked = move |scale| {
            let (r, filled, path) = marker(l.shape, scale);
            let style = if filled {
                l.color.filled()
            } else {
                l.color.stroke_width(2)
            };
            (Circle::new((0, 0), r, style), PathElement::new(path, style))
        };
        anno.label(label).legend(move |(x, y)| {
            // the dash pattern over 60 pixels, the marker in the middle
            let (on, off) = l.dash.map_or((60, 0), |(a, b)| (a as i32, b as i32));
            let segment = |k: i32| {
                let a = (k * (on + off) - 30).min(30);
                PathElement::new(vec![(a, 0), ((a + on).min(30), 0)], style)
            };
            let (circle, path) = marked(0.65);
            EmptyElement::at((x + 30, y))
                + segment(0)
                + segment(1)
                + segment(2)
                + segment(3)
                + segment(4)
                + segment(5)
                + segment(6)
                + circle
                + path
        });
        if l.shape.is_some() {
            chart.draw_series(pts.iter().map(|&p| {
                let (circle, path) = marked(1.0);
                EmptyElement::at(p) + circle + path
            }))?;
        }
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .legend_area_size(64)
        .label_font(("sans-serif", 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A rate, its eq. (12) count, and each series' k_max and whether it reached the cap.
    type TestRow<'a> = (f64, u64, &'a [(usize, bool)]);

    fn out(rows: &[TestRow]) -> SweepOut {
        let names = ["round-robin", "earliest-deadline"];
        SweepOut {
            clock_hz: 50e6,
            interval_cycles: 32,
            latency_cycles: 50,
            move_times_s: [0.02, 0.01, 0.02],
            rows: rows
                .iter()
                .map(|&(rate, k_eq12, series)| Row {
                    rate_steps_per_s: rate,
                    min_period_ticks: (50e6 / rate) as u64,
                    k_eq12,
                    series: series
                        .iter()
                        .enumerate()
                        .map(|(i, &(k_max, capped))| Series {
                            policy: names[i % 2],
                            fifo_depth: 1 + i / 2,
                            k_max,
                            capped,
                        })
                        .collect(),
                })
                .collect(),
        }
    }

    #[test]
    fn eq12_is_drawn_whole_inside_the_y_range() {
        // the pipelined sweep's first rows: eq. (12) above the 64 axes tried
        let o = out(&[
            (20e3, 78, &[(64, true), (64, true)]),
            (40e3, 39, &[(38, false), (39, false)]),
            (10e3, 156, &[(64, true), (64, true)]),
        ]);
        let d = plot_data(&o);
        assert_eq!(d.eq12, vec![(20.0, 78.0), (40.0, 39.0), (10.0, 156.0)]);
        for &(x, y) in d.eq12.iter().chain(d.series.iter().flat_map(|(_, p)| p)) {
            assert!(
                d.x.contains(&x) && d.y.contains(&y),
                "({x}, {y}) outside {:?} × {:?}",
                d.x,
                d.y
            );
            // and not on the frame, where the line would be half hidden
            assert!(y < d.y.end - 1.0 && x < d.x.end, "({x}, {y})");
        }
        assert_eq!(d.cap, Some(64.0));
    }

    #[test]
    fn coinciding_series_say_which_line_they_follow() {
        let o = out(&[
            (
                100e3,
                10,
                &[(10, false), (10, false), (9, false), (9, false)],
            ),
            (200e3, 5, &[(5, false), (5, false), (5, false), (5, false)]),
        ]);
        let d = plot_data(&o);
        assert_eq!(
            d.same_as,
            [
                Some("eq. (12)".to_string()),
                Some("eq. (12)".to_string()),
                None,
                Some("round-robin D=2".to_string()),
            ]
        );
        assert_eq!(d.cap, None);
        // every series looks different from the others it may lie on
        let looks: Vec<Look> = (0..4).map(look).collect();
        for (i, a) in looks.iter().enumerate() {
            for b in &looks[i + 1..] {
                assert!(a.color != b.color && a.shape != b.shape && a.width > b.width);
            }
        }
    }
}
