//! Output: one CSV per scene and a combined CSV, one SVG chart per scene (time per step
//! against error, log-log, one series per impact3d method and per peer, Pareto front and
//! tolerance marked), a summary chart with every scene, and the end table (also written as
//! `summary.md`).

use std::fmt::Write as _;
use std::io;
use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::measure::RunResult;
use crate::scenes::Scene;
use crate::sweep::RunConfig;

/// One run, as written to the CSV files.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// Scene name.
    pub scene: &'static str,
    /// "impact3d", "avian3d" or "rapier3d".
    pub engine: &'static str,
    /// impact3d method, or "default" for a peer.
    pub method: String,
    /// Chart series.
    pub series: String,
    /// Short description of the configuration.
    pub label: String,
    /// Iterations (impact3d per substep; Rapier's solver iterations).
    pub iterations: u32,
    /// Substeps.
    pub substeps: u32,
    /// Steps per second.
    pub hz: u32,
    /// The engine's (method's) own substeps and iterations.
    pub default_settings: bool,
    /// Steps run.
    pub steps: usize,
    /// Median wall time of one physics step, ms (the fastest round's).
    pub ms_per_step: f64,
    /// Spread of the rounds' medians: slowest / fastest - 1.
    pub ms_spread: f64,
    /// The scene's error.
    pub error: f64,
    /// Unit of the error.
    pub unit: &'static str,
    /// The scene's tolerance on the error.
    pub tolerance: f64,
    /// Deepest penetration, m.
    pub penetration: f64,
    /// Largest displacement, m.
    pub drift: f64,
    /// Relative change of mechanical energy.
    pub energy_change: f64,
}

impl Row {
    /// The row of one configuration: `result` from its first round, `times` the median ms per
    /// step of every round.
    pub fn new(scene: &Scene, config: &RunConfig, result: RunResult, times: &[f64]) -> Self {
        let fastest = times.iter().copied().fold(f64::INFINITY, f64::min);
        let slowest = times.iter().copied().fold(0.0, f64::max);
        Row {
            scene: scene.name,
            engine: config.engine_name(),
            method: config.method(),
            series: config.series(),
            label: config.label(),
            iterations: config.iterations,
            substeps: config.substeps,
            hz: config.hz,
            default_settings: config.default_settings,
            steps: result.steps,
            ms_per_step: fastest,
            ms_spread: if fastest > 0.0 {
                slowest / fastest - 1.0
            } else {
                0.0
            },
            error: result.metrics.error,
            unit: scene.unit,
            tolerance: scene.tolerance,
            penetration: result.metrics.penetration,
            drift: result.metrics.drift,
            energy_change: result.metrics.energy_change,
        }
    }

    /// The error is finite and within the tolerance.
    pub fn passes(&self) -> bool {
        self.error.is_finite() && self.error <= self.tolerance
    }
}

/// The CSV header, shared by every CSV file.
pub const CSV_HEADER: &str = "scene,engine,method,iterations,substeps,dt,hz,default_settings,steps,ms_per_step,ms_spread,error,error_unit,tolerance,pass,penetration_m,drift_m,energy_change";

fn csv_line(r: &Row) -> String {
    format!(
        "{},{},{},{},{},{:.9},{},{},{},{:.6},{:.3},{:.6e},{},{:e},{},{:.6e},{:.6e},{:.6e}",
        r.scene,
        r.engine,
        r.method,
        r.iterations,
        r.substeps,
        1.0 / r.hz as f64,
        r.hz,
        r.default_settings,
        r.steps,
        r.ms_per_step,
        r.ms_spread,
        r.error,
        r.unit,
        r.tolerance,
        r.passes(),
        r.penetration,
        r.drift,
        r.energy_change
    )
}

fn write_csv(path: &Path, rows: &[&Row]) -> io::Result<()> {
    let mut text = String::from(CSV_HEADER);
    text.push('\n');
    for r in rows {
        text.push_str(&csv_line(r));
        text.push('\n');
    }
    std::fs::write(path, text)
}

/// Writes `<scene>.csv`, `<scene>.svg`, `combined.csv`, `summary.svg` and `summary.md` into
/// `out`.
pub fn write_all(out: &Path, scenes: &[Scene], rows: &[Row]) -> io::Result<()> {
    let chart_error = |e: Box<dyn std::error::Error>| io::Error::other(e.to_string());
    for scene in scenes {
        let own: Vec<&Row> = rows.iter().filter(|r| r.scene == scene.name).collect();
        write_csv(&out.join(format!("{}.csv", scene.name)), &own)?;
        draw_scene_file(&out.join(format!("{}.svg", scene.name)), scene, &own)
            .map_err(chart_error)?;
    }
    write_csv(&out.join("combined.csv"), &rows.iter().collect::<Vec<_>>())?;
    draw_summary(&out.join("summary.svg"), scenes, rows).map_err(chart_error)?;
    std::fs::write(
        out.join("summary.md"),
        format!("{}\n", end_table(scenes, rows)),
    )
}

/// Errors below this are drawn at it (a log axis has no zero).
const ERROR_FLOOR: f64 = 1e-7;
/// Non-finite errors (a run that blew up) and errors above this are drawn at it.
const ERROR_CEILING: f64 = 1e3;

/// How a series is drawn.
#[derive(Clone, Copy)]
enum Marker {
    Circle,
    Triangle,
    Square,
}

/// Colour and marker of each series, in legend order.
const SERIES: [(&str, RGBColor, Marker); 7] = [
    ("impact3d Hybrid", RGBColor(31, 119, 180), Marker::Circle),
    (
        "impact3d Propagation",
        RGBColor(44, 160, 44),
        Marker::Circle,
    ),
    (
        "impact3d SequentialImpulses",
        RGBColor(148, 103, 189),
        Marker::Circle,
    ),
    ("impact3d SoftStep", RGBColor(23, 190, 207), Marker::Circle),
    ("impact3d Jacobi", RGBColor(140, 86, 75), Marker::Circle),
    ("avian3d", RGBColor(255, 127, 14), Marker::Triangle),
    ("rapier3d", RGBColor(214, 39, 40), Marker::Square),
];

fn plotted_error(error: f64) -> f64 {
    if error.is_finite() {
        error.clamp(ERROR_FLOOR, ERROR_CEILING)
    } else {
        ERROR_CEILING
    }
}

/// The runs no other run beats on both time and error, cheapest first.
pub fn pareto_front<'a>(rows: &[&'a Row]) -> Vec<&'a Row> {
    let mut sorted: Vec<&Row> = rows
        .iter()
        .copied()
        .filter(|r| r.error.is_finite())
        .collect();
    sorted.sort_by(|a, b| {
        a.ms_per_step
            .total_cmp(&b.ms_per_step)
            .then(a.error.total_cmp(&b.error))
    });
    let mut best = f64::INFINITY;
    sorted
        .into_iter()
        .filter(|r| {
            let better = r.error < best;
            best = best.min(r.error);
            better
        })
        .collect()
}

type DrawResult = Result<(), Box<dyn std::error::Error>>;

/// Draws one scene's chart (scatter, Pareto front, tolerance) into `area`; `large` for a
/// chart of its own, else a panel of the summary.
fn draw_scene<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    scene: &Scene,
    rows: &[&Row],
    large: bool,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    area.fill(&WHITE)?;
    let times: Vec<f64> = rows.iter().map(|r| r.ms_per_step.max(1e-6)).collect();
    let errors: Vec<f64> = rows.iter().map(|r| plotted_error(r.error)).collect();
    let (t_lo, t_hi) = min_max(&times).unwrap_or((1e-3, 1.0));
    let (e_lo, e_hi) = min_max(&errors).unwrap_or((ERROR_FLOOR, 1.0));
    let (x0, x1) = (t_lo / 1.5, t_hi * 1.5);
    let (y0, y1) = (
        e_lo.min(scene.tolerance) / 3.0,
        e_hi.max(scene.tolerance) * 3.0,
    );
    let caption = if large {
        format!(
            "{}: error against time per step; tolerance {:e} ({})",
            scene.name, scene.tolerance, scene.unit
        )
    } else {
        format!("{} (tol {:e})", scene.name, scene.tolerance)
    };
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", if large { 20 } else { 15 }))
        .margin(8)
        .x_label_area_size(if large { 40 } else { 30 })
        .y_label_area_size(if large { 70 } else { 55 })
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("ms per step")
        .y_desc(format!("error ({})", scene.unit))
        .x_label_formatter(&|x| format!("{x:.1e}"))
        .y_label_formatter(&|y| format!("{y:.0e}"))
        .x_labels(if large { 10 } else { 5 })
        .y_labels(if large { 8 } else { 5 })
        .label_style(("sans-serif", if large { 12 } else { 10 }))
        .draw()?;
    chart.draw_series(DashedLineSeries::new(
        [(x0, scene.tolerance), (x1, scene.tolerance)],
        6,
        4,
        RGBColor(120, 120, 120).stroke_width(1),
    ))?;
    let front: Vec<(f64, f64)> = pareto_front(rows)
        .iter()
        .map(|r| (r.ms_per_step.max(1e-6), plotted_error(r.error)))
        .collect();
    let mut path: Vec<(f64, f64)> = Vec::new();
    for &point in &front {
        if let Some(&(_, y)) = path.last() {
            path.push((point.0, y));
        }
        path.push(point);
    }
    chart.draw_series(LineSeries::new(path, BLACK.stroke_width(1)))?;
    chart.draw_series(
        front
            .iter()
            .map(|&p| Circle::new(p, 7, BLACK.stroke_width(1))),
    )?;
    for (name, color, marker) in SERIES {
        let points: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| r.series == name)
            .map(|r| (r.ms_per_step.max(1e-6), plotted_error(r.error)))
            .collect();
        let style = color.filled();
        match marker {
            Marker::Circle => {
                chart.draw_series(points.iter().map(|&p| Circle::new(p, 4, style)))?
            }
            Marker::Triangle => {
                chart.draw_series(points.iter().map(|&p| TriangleMarker::new(p, 6, style)))?
            }
            Marker::Square => chart.draw_series(
                points
                    .iter()
                    .map(|&p| EmptyElement::at(p) + Rectangle::new([(-4, -4), (4, 4)], style)),
            )?,
        };
    }
    // The engines' own settings at 60 Hz get a grey ring.
    chart.draw_series(
        rows.iter()
            .filter(|r| r.default_settings && r.hz == 60)
            .map(|r| {
                Circle::new(
                    (r.ms_per_step.max(1e-6), plotted_error(r.error)),
                    10,
                    RGBColor(150, 150, 150).stroke_width(2),
                )
            }),
    )?;
    Ok(())
}

/// One scene's chart as its own SVG file: the chart, the legend beside it, the scene's
/// description under it.
fn draw_scene_file(path: &Path, scene: &Scene, rows: &[&Row]) -> DrawResult {
    let root = SVGBackend::new(path, (1100, 640)).into_drawing_area();
    root.fill(&WHITE)?;
    let (main, footer) = root.split_vertically(610);
    let (chart, legend) = main.split_horizontally(820);
    draw_scene(&chart, scene, rows, true)?;
    draw_legend(&legend)?;
    footer.draw_text(
        &scene.description,
        &("sans-serif", 13).into_font().color(&BLACK),
        (12, 6),
    )?;
    root.present()?;
    Ok(())
}

/// The legend: one marker per series, then what the lines and rings mean.
fn draw_legend<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let font = ("sans-serif", 14).into_font().color(&BLACK);
    let mut y = 40;
    for (name, color, marker) in SERIES {
        let at = (30, y);
        match marker {
            Marker::Circle => area.draw(&Circle::new(at, 5, color.filled()))?,
            Marker::Triangle => area.draw(&TriangleMarker::new(at, 7, color.filled()))?,
            Marker::Square => area.draw(
                &(EmptyElement::at(at) + Rectangle::new([(-5, -5), (5, 5)], color.filled())),
            )?,
        }
        area.draw_text(name, &font, (45, y - 7))?;
        y += 24;
    }
    y += 10;
    for line in [
        "black line + black rings: Pareto front",
        "grey ring: default settings at 60 Hz",
        "dashed line: the scene's tolerance",
        "errors < 1e-7 drawn at 1e-7;",
        "exploded runs at 1e3",
    ] {
        area.draw_text(line, &font, (20, y - 7))?;
        y += 20;
    }
    Ok(())
}

fn min_max(values: &[f64]) -> Option<(f64, f64)> {
    let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    (lo <= hi).then_some((lo, hi))
}

/// The summary: every scene's chart in one grid, a legend panel, and the machine and date.
fn draw_summary(path: &Path, scenes: &[Scene], rows: &[Row]) -> DrawResult {
    let cols = 4;
    let panels = scenes.len() + 1;
    let grid_rows = panels.div_ceil(cols);
    let root =
        SVGBackend::new(path, (cols as u32 * 420, grid_rows as u32 * 320 + 50)).into_drawing_area();
    root.fill(&WHITE)?;
    let title = format!(
        "impact3d lab: median time per physics step (x, log) against error (y, log); {}",
        machine_and_date()
    );
    let body = root.titled(&title, ("sans-serif", 22))?;
    let areas = body.split_evenly((grid_rows, cols));
    for (scene, area) in scenes.iter().zip(&areas) {
        let own: Vec<&Row> = rows.iter().filter(|r| r.scene == scene.name).collect();
        draw_scene(area, scene, &own, false)?;
    }
    draw_legend(&areas[scenes.len()])?;
    root.present()?;
    Ok(())
}

/// "<cpu>, <n> cores, <date>" for chart titles.
pub fn machine_and_date() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|s| s.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    format!("{cpu}, {cores} cores, single-threaded, {}", today())
}

/// Today's date (UTC) as YYYY-MM-DD, from the system clock (civil-from-days).
fn today() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let z = (secs / 86_400) as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!("{year:04}-{month:02}-{day:02}")
}

/// The cheapest run of `engine` on `scene` that meets the tolerance.
fn cheapest<'a>(rows: &'a [Row], scene: &str, engine: &str) -> Option<&'a Row> {
    rows.iter()
        .filter(|r| r.scene == scene && r.engine == engine && r.passes())
        .min_by(|a, b| a.ms_per_step.total_cmp(&b.ms_per_step))
}

/// The default run at 60 Hz of `series` on `scene`.
fn default_at_60<'a>(rows: &'a [Row], scene: &str, series: &str) -> Option<&'a Row> {
    rows.iter()
        .find(|r| r.scene == scene && r.series == series && r.default_settings && r.hz == 60)
}

fn cell(row: Option<&Row>, with_label: bool) -> String {
    match row {
        Some(r) if with_label => {
            format!("{} {:.4} ms, err {:.2e}", r.label, r.ms_per_step, r.error)
        }
        Some(r) => format!(
            "{:.4} ms, err {:.2e}{}",
            r.ms_per_step,
            r.error,
            if r.passes() { "" } else { " FAIL" }
        ),
        None => "none passes".into(),
    }
}

fn ratio(a: Option<&Row>, b: Option<&Row>) -> String {
    match (a, b) {
        (Some(a), Some(b)) if b.ms_per_step > 0.0 => {
            format!("{:.2}", a.ms_per_step / b.ms_per_step)
        }
        _ => "-".into(),
    }
}

/// The end table, in Markdown: for each scene the cheapest configuration of each engine that
/// meets the tolerance and impact3d's time as a ratio of each peer's; then every engine's
/// defaults at 60 Hz side by side.
pub fn end_table(scenes: &[Scene], rows: &[Row]) -> String {
    let peers = rows.iter().any(|r| r.engine != "impact3d");
    let mut t = String::new();
    let _ = writeln!(
        t,
        "Cheapest configuration meeting each scene's tolerance (median ms per physics step; ratio = impact3d / peer)\n"
    );
    if peers {
        let _ = writeln!(
            t,
            "| scene | tolerance | impact3d | avian3d | rapier3d | ratio vs avian3d | ratio vs rapier3d |"
        );
        let _ = writeln!(t, "|---|---|---|---|---|---|---|");
    } else {
        let _ = writeln!(t, "| scene | tolerance | impact3d |");
        let _ = writeln!(t, "|---|---|---|");
    }
    for s in scenes {
        let i = cheapest(rows, s.name, "impact3d");
        let _ = write!(
            t,
            "| {} | {:e} {} | {} |",
            s.name,
            s.tolerance,
            s.unit,
            cell(i, true)
        );
        if peers {
            let a = cheapest(rows, s.name, "avian3d");
            let r = cheapest(rows, s.name, "rapier3d");
            let _ = write!(
                t,
                " {} | {} | {} | {} |",
                cell(a, true),
                cell(r, true),
                ratio(i, a),
                ratio(i, r)
            );
        }
        t.push('\n');
    }
    let _ = writeln!(
        t,
        "\nDefault settings at 60 Hz (FAIL: above the tolerance)\n"
    );
    let series: Vec<&str> = SERIES
        .iter()
        .map(|s| s.0)
        .filter(|name| rows.iter().any(|r| r.series == *name))
        .collect();
    let _ = writeln!(t, "| scene | {} |", series.join(" | "));
    let _ = writeln!(t, "|---|{}", "---|".repeat(series.len()));
    for s in scenes {
        let cells: Vec<String> = series
            .iter()
            .map(|name| cell(default_at_60(rows, s.name, name), false))
            .collect();
        let _ = writeln!(t, "| {} | {} |", s.name, cells.join(" | "));
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(ms: f64, error: f64) -> Row {
        Row {
            scene: "s",
            engine: "impact3d",
            method: "Hybrid".into(),
            series: "impact3d Hybrid".into(),
            label: String::new(),
            iterations: 1,
            substeps: 1,
            hz: 60,
            default_settings: true,
            steps: 1,
            ms_per_step: ms,
            ms_spread: 0.0,
            error,
            unit: "m",
            tolerance: 0.1,
            penetration: 0.0,
            drift: 0.0,
            energy_change: 0.0,
        }
    }

    #[test]
    fn pareto_front_keeps_only_undominated_runs() {
        let rows = [
            row(1.0, 0.5),
            row(2.0, 0.6),
            row(3.0, 0.1),
            row(0.5, f64::INFINITY),
            row(4.0, 0.1),
        ];
        let refs: Vec<&Row> = rows.iter().collect();
        let front: Vec<(f64, f64)> = pareto_front(&refs)
            .iter()
            .map(|r| (r.ms_per_step, r.error))
            .collect();
        assert_eq!(front, vec![(1.0, 0.5), (3.0, 0.1)]);
    }

    #[test]
    fn date_is_iso() {
        let d = today();
        assert_eq!(d.len(), 10);
        assert!(d.starts_with("20"));
    }
}
