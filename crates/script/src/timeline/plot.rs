//! `shoal diff --plot`: both runs' paths seen from above, the first run as grey ghosts under the
//! second in colour, each fish's first divergence marked.

use std::collections::HashMap;
use std::path::Path;

use plotters::prelude::*;

use super::RunDiff;
use super::run_file::Run;
use crate::plot::{PlotError, fonts_work, top_view_axes};

pub(super) const BACKGROUND: RGBColor = RGBColor(250, 250, 247);
const WATER: RGBColor = RGBColor(214, 232, 240);
const TANK_EDGE: RGBColor = RGBColor(60, 90, 110);
const GHOST: RGBColor = RGBColor(150, 150, 150);
pub(super) const COLORS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
    RGBColor(140, 86, 75),
    RGBColor(188, 189, 34),
];

/// Diverged fish named in the diff plot's legend (the others by the ends of their paths).
const LEGEND_FISH: usize = 10;

/// Each fish's path (x, z) over the first `n` frames, by (index, generation).
fn paths(run: &Run, n: usize) -> HashMap<(u32, u32), Vec<(f32, f32)>> {
    let mut out: HashMap<(u32, u32), Vec<(f32, f32)>> = HashMap::new();
    for frame in run.frames.iter().take(n) {
        for p in frame {
            out.entry((p.index, p.generation))
                .or_default()
                .push((p.pos.x, p.pos.z));
        }
    }
    out
}

/// Draws `a` (ghosts) and `b` (colour) from above into a PNG at `path`; the fish that diverged
/// get colours, the others are drawn thin.
pub fn write(a: &Run, b: &Run, d: &RunDiff, path: &Path) -> Result<(), PlotError> {
    let err = |e| PlotError::figure(path, e);
    let text = fonts_work();
    let [min, max] = b.header.tank;
    let (w, h) = ((max[0] - min[0]).max(1e-3), (max[2] - min[2]).max(1e-3));
    let plot_w = 1000u32;
    let axes = if text { 70 } else { 10 };
    let plot_h = ((plot_w as f32) * (h / w)).clamp(250.0, 1000.0) as u32;
    let root =
        BitMapBackend::new(path, (plot_w + axes + 20, plot_h + axes + 60)).into_drawing_area();
    root.fill(&BACKGROUND).map_err(err)?;
    let mut builder = ChartBuilder::on(&root);
    builder.margin(16);
    if text {
        let caption = match d.first_divergence_s {
            Some(t) => format!(
                "seen from above: after the ring where they part, grey = first run, colour = second (first parting {t:.2} s)"
            ),
            None => "seen from above: the runs are identical".to_owned(),
        };
        builder
            .caption(caption, ("sans-serif", 20))
            .x_label_area_size(44)
            .y_label_area_size(56);
    }
    let mut chart = builder
        .build_cartesian_2d(min[0]..max[0], max[2]..min[2])
        .map_err(err)?;
    if text {
        top_view_axes(&mut chart).map_err(err)?;
    }
    let area = chart.plotting_area().clone();
    let tank = [(min[0], min[2]), (max[0], max[2])];
    area.draw(&Rectangle::new(tank, WATER.mix(0.6).filled()))
        .map_err(err)?;
    area.draw(&Rectangle::new(tank, TANK_EDGE.stroke_width(3)))
        .map_err(err)?;
    let n = a.frames.len().min(b.frames.len());
    let (pa, pb) = (paths(a, n), paths(b, n));
    let mut keys: Vec<_> = pb.keys().copied().collect();
    keys.sort_unstable();
    let name_of = |k: &(u32, u32)| {
        if k.1 == 0 {
            format!("#{}", k.0)
        } else {
            format!("#{}.{}", k.0, k.1)
        }
    };
    let diverged = |k: &(u32, u32)| {
        let name = name_of(k);
        d.fish
            .iter()
            .find(|f| f.fish == name)
            .and_then(|f| f.first_divergence_s)
    };
    let shared = TANK_EDGE.mix(0.45).stroke_width(1);
    let mut legend = 0usize;
    for (i, k) in keys.iter().enumerate() {
        let points = &pb[k];
        let Some(t) = diverged(k) else {
            // The same in both runs: one thin line.
            area.draw(&PathElement::new(points.clone(), shared))
                .map_err(err)?;
            continue;
        };
        // Shared up to the divergence, then the first run as a grey ghost and the second in
        // colour, from a ring where they part to a dot where they end.
        let at = ((t * b.header.tick_hz).round() as usize).min(points.len().saturating_sub(1));
        area.draw(&PathElement::new(points[..=at].to_vec(), shared))
            .map_err(err)?;
        if let Some(ghost) = pa.get(k) {
            let from = at.min(ghost.len().saturating_sub(1));
            area.draw(&PathElement::new(
                ghost[from..].to_vec(),
                GHOST.stroke_width(3),
            ))
            .map_err(err)?;
        }
        let c = COLORS[i % COLORS.len()];
        let series = chart
            .draw_series(std::iter::once(PathElement::new(
                points[at..].to_vec(),
                c.stroke_width(2),
            )))
            .map_err(err)?;
        // Which colour is which fish: the legend names the first few, and every coloured path
        // carries its fish's name at its end (colours repeat past eight fish).
        if text && legend < LEGEND_FISH {
            series
                .label(format!("{} (parts at {t:.2} s)", name_of(k)))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(3))
                });
            legend += 1;
        }
        let area = chart.plotting_area();
        area.draw(&Circle::new(points[at], 6, c.stroke_width(2)))
            .map_err(err)?;
        if let Some(&last) = points.last() {
            area.draw(&Circle::new(last, 5, c.filled())).map_err(err)?;
            if text {
                area.draw(&Text::new(
                    name_of(k),
                    last,
                    ("sans-serif", 14).into_font().color(&c),
                ))
                .map_err(err)?;
            }
        }
    }
    if text && legend > 0 {
        let hidden = d
            .fish
            .iter()
            .filter(|f| f.first_divergence_s.is_some())
            .count()
            - legend;
        if hidden > 0 {
            chart
                .draw_series(std::iter::empty::<Circle<(f32, f32), i32>>())
                .map_err(err)?
                .label(format!("… {hidden} more (named at their paths' ends)"))
                .legend(|(x, y)| Circle::new((x + 10, y), 0, BACKGROUND));
        }
        chart
            .draw_series(std::iter::empty::<Circle<(f32, f32), i32>>())
            .map_err(err)?
            .label("grey: the first run after the fish parts")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], GHOST.stroke_width(3)));
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(BACKGROUND.mix(0.85))
            .border_style(TANK_EDGE)
            .label_font(("sans-serif", 14))
            .draw()
            .map_err(err)?;
    }
    root.present().map_err(err)
}
