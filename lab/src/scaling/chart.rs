//! `scaling.svg`: time per body against N, one panel per scene, one line per engine (and
//! impact3d thread count), both axes on log scales. A flat line is linear scaling.

use std::path::Path;

use plotters::prelude::*;

use super::{Family, ScaleRow};

/// Colours of the lines, in the order the engines first appear in the rows.
const COLOURS: [RGBColor; 6] = [
    RGBColor(214, 39, 40),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
];

/// Draws the chart of `rows` into `path`.
pub fn draw(path: &Path, rows: &[ScaleRow]) -> Result<(), Box<dyn std::error::Error>> {
    let root = SVGBackend::new(path, (1100, 460)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut labels: Vec<String> = Vec::new();
    for r in rows {
        if !labels.contains(&r.label()) {
            labels.push(r.label());
        }
    }
    let panels = root.split_evenly((1, 2));
    for (area, family) in panels.iter().zip([Family::Flight, Family::Pour]) {
        let of: Vec<&ScaleRow> = rows.iter().filter(|r| r.family == family).collect();
        let (Some(n0), Some(n1)) = (of.iter().map(|r| r.n).min(), of.iter().map(|r| r.n).max())
        else {
            continue;
        };
        let us: Vec<f64> = of.iter().map(|r| r.us_per_body().max(1e-6)).collect();
        let lo = us.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = us.iter().copied().fold(0.0, f64::max);
        let x = (n0 as f64 / 1.3)..(n1 as f64 * 1.3);
        let mut chart = ChartBuilder::on(area)
            .caption(
                format!("{}: us per body per step against N", family.name()),
                ("sans-serif", 16),
            )
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(55)
            .build_cartesian_2d(x.log_scale(), ((lo / 1.5)..(hi * 1.5)).log_scale())?;
        chart
            .configure_mesh()
            .x_desc("bodies")
            .y_desc("us per body")
            .x_label_formatter(&|n| format!("{n:.0}"))
            .y_label_formatter(&|u| format!("{u:.2}"))
            .label_style(("sans-serif", 11))
            .draw()?;
        for (k, label) in labels.iter().enumerate() {
            let mut points: Vec<(f64, f64)> = of
                .iter()
                .filter(|r| &r.label() == label)
                .map(|r| (r.n as f64, r.us_per_body().max(1e-6)))
                .collect();
            if points.is_empty() {
                continue;
            }
            points.sort_by(|a, b| a.0.total_cmp(&b.0));
            let colour = COLOURS[k % COLOURS.len()];
            chart
                .draw_series(LineSeries::new(points.clone(), colour.stroke_width(2)))?
                .label(label.clone())
                .legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 18, y)], colour.stroke_width(2))
                });
            chart.draw_series(points.iter().map(|&p| Circle::new(p, 4, colour.filled())))?;
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .label_font(("sans-serif", 12))
            .position(SeriesLabelPosition::UpperLeft)
            .draw()?;
    }
    root.present()?;
    Ok(())
}
