//! `shoal compare --plot` ([`write`]): one panel per measure, each seed's A and B joined by a line (the runs
//! are paired by seed), each version's mean with its 95 % interval beside them.

use std::path::Path;

use plotters::prelude::*;

use super::compare::{Comparison, Estimate, value};
use crate::plot::{PlotError, fonts_work};

use super::plot::{BACKGROUND, COLORS};

const PAIR: RGBColor = RGBColor(175, 175, 175);
/// Version A in the diff plot's first colour (blue), B in its orange.
const A_COLOR: RGBColor = COLORS[0];
const B_COLOR: RGBColor = COLORS[4];
const SIGNIFICANT: RGBColor = RGBColor(180, 30, 30);

/// Draws the comparison into a PNG at `path`.
pub fn write(c: &Comparison, path: &Path) -> Result<(), PlotError> {
    let err = |e: &dyn std::fmt::Display| PlotError::write(path, e);
    let text = fonts_work();
    let (cols, rows) = (3usize, c.summary.len().div_ceil(3));
    let root = BitMapBackend::new(path, (1500, 60 + 330 * rows as u32)).into_drawing_area();
    root.fill(&BACKGROUND).map_err(|e| err(&e))?;
    let (title, body) = root.split_vertically(60);
    if text {
        let seeds = c.a.runs.len();
        title
            .draw(&Text::new(
                format!(
                    "{}: A = {} (blue), B = {} (orange), {seeds} seeds × {} s; lines join a seed's runs, bars are 95 % intervals",
                    c.scene, c.a.dir, c.b.dir, c.seconds
                ),
                (16, 20),
                ("sans-serif", 18).into_font(),
            ))
            .map_err(|e| err(&e))?;
    }
    let panels = body.split_evenly((rows, cols));
    for (panel, summary) in panels.iter().zip(&c.summary) {
        let key = summary.measure.as_str();
        let a: Vec<(u64, f64)> =
            c.a.runs
                .iter()
                .filter_map(|r| Some((r.seed, value(key, r)?)))
                .collect();
        let b: Vec<(u64, f64)> =
            c.b.runs
                .iter()
                .filter_map(|r| Some((r.seed, value(key, r)?)))
                .collect();
        let all = a.iter().chain(&b).map(|v| v.1);
        let (lo, hi) = all.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
            (l.min(v), h.max(v))
        });
        let (lo, hi) = if !lo.is_finite() {
            (0.0, 1.0)
        } else if hi - lo < 1e-9 {
            // Every run the same: centre it in a range a label can read.
            let pad = (0.1 * hi.abs()).max(0.5);
            (lo - pad, hi + pad)
        } else {
            let pad = (hi - lo) * 0.1;
            (lo - pad, hi + pad)
        };
        let decimals = if hi - lo >= 20.0 {
            0
        } else if hi - lo >= 2.0 {
            1
        } else {
            3
        };
        let mut builder = ChartBuilder::on(panel);
        builder.margin(12);
        if text {
            let verdict = match summary.b_minus_a.mean {
                Some(d) if summary.significant => format!("B − A = {d:+.3}, significant"),
                Some(d) => format!("B − A = {d:+.3}, not significant"),
                None => "no pairs".to_owned(),
            };
            let color = if summary.significant {
                SIGNIFICANT
            } else {
                RGBColor(40, 40, 40)
            };
            builder
                .caption(
                    format!("{}: {verdict}", summary.label),
                    ("sans-serif", 17).into_font().color(&color),
                )
                .y_label_area_size(60)
                .x_label_area_size(24);
        }
        let mut chart = builder
            .build_cartesian_2d(-0.6f64..1.6f64, lo..hi)
            .map_err(|e| err(&e))?;
        if text {
            chart
                .configure_mesh()
                .disable_x_mesh()
                .x_labels(3)
                .x_label_formatter(&|x| match x.round() as i32 {
                    0 => "A".into(),
                    1 => "B".into(),
                    _ => String::new(),
                })
                .y_label_formatter(&|v| format!("{v:.decimals$}"))
                .light_line_style(RGBColor(235, 235, 235))
                .draw()
                .map_err(|e| err(&e))?;
        }
        let area = chart.plotting_area();
        for &(seed, va) in &a {
            if let Some(&(_, vb)) = b.iter().find(|(s, _)| *s == seed) {
                area.draw(&PathElement::new(vec![(0.0, va), (1.0, vb)], PAIR))
                    .map_err(|e| err(&e))?;
            }
        }
        for (x, values, color) in [(0.0, &a, A_COLOR), (1.0, &b, B_COLOR)] {
            for &(_, v) in values {
                area.draw(&Circle::new((x, v), 3, color.filled()))
                    .map_err(|e| err(&e))?;
            }
        }
        for (x, e, color) in [(-0.3, summary.a, A_COLOR), (1.3, summary.b, B_COLOR)] {
            draw_estimate(area, x, e, color).map_err(|e| err(&e))?;
        }
    }
    root.present().map_err(|e| err(&e))
}

fn draw_estimate<DB: DrawingBackend>(
    area: &DrawingArea<
        DB,
        plotters::coord::cartesian::Cartesian2d<
            plotters::coord::types::RangedCoordf64,
            plotters::coord::types::RangedCoordf64,
        >,
    >,
    x: f64,
    e: Estimate,
    color: RGBColor,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let Some(mean) = e.mean else { return Ok(()) };
    if let (Some(l), Some(h)) = (e.low, e.high) {
        area.draw(&PathElement::new(
            vec![(x, l), (x, h)],
            color.stroke_width(3),
        ))?;
        for y in [l, h] {
            area.draw(&PathElement::new(
                vec![(x - 0.08, y), (x + 0.08, y)],
                color.stroke_width(2),
            ))?;
        }
    }
    area.draw(&Rectangle::new(
        [(x - 0.1, mean), (x + 0.1, mean)],
        color.stroke_width(4),
    ))?;
    area.draw(&Circle::new((x, mean), 6, color.filled()))
}
