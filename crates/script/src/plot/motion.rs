//! The motion figure of `shoal plot`: a preset's body midlines (paper Fig. 4, 6) and, seen from
//! above, the body along its path (Fig. 7–9).

use std::path::Path;

use glam::Vec3;
use plotters::coord::Shift;
use plotters::prelude::*;

use super::{PlotError, fonts_work, plot_err};
use shoal_core::motion::{Body, MidlinePoseJob, Preset, Recording, record_preset, wave};

/// Samples per second of the plotted motion.
const RATE_HZ: f32 = 120.0;
/// Midline samples along the body for the smooth curves of the left panel.
const FINE_SEGMENTS: usize = 60;

/// Time colour: blue (start) to red (end) for `u` in [0, 1].
fn time_color(u: f32) -> HSLColor {
    HSLColor(0.62 * (1.0 - f64::from(u.clamp(0.0, 1.0))), 0.85, 0.42)
}

/// The span of the recording worth drawing: the whole turn plus a little swim after it, or one
/// tail-beat cycle for a swim.
fn window(rec: &Recording, preset: &Preset) -> (usize, usize) {
    let is_turn = |m: &str| m.ends_with("_turn");
    match rec.frames.iter().rposition(|f| is_turn(f.motion)) {
        Some(last) if preset.turn.is_some() => {
            let extra = (0.4 * RATE_HZ) as usize;
            (0, (last + extra).min(rec.frames.len() - 1))
        }
        _ => {
            let cycle = 1.0 / preset.params.tail_beat_hz(preset.params.s).max(0.1);
            let n = (cycle * RATE_HZ).round() as usize;
            (0, n.min(rec.frames.len() - 1))
        }
    }
}

/// Draws the figure for `preset` into `out` (PNG). Returns whether text could be drawn (without a
/// usable font the figure is drawn without captions, labels and title rather than failing).
pub fn draw(preset: &Preset, out: &Path, size: (u32, u32)) -> Result<bool, PlotError> {
    let text = fonts_work();
    draw_figure(preset, out, size, text)?;
    Ok(text)
}

/// Draws the figure, with text or without (the fallback when no font can be loaded).
pub fn draw_figure(
    preset: &Preset,
    out: &Path,
    size: (u32, u32),
    text: bool,
) -> Result<(), PlotError> {
    let p = preset.params;
    let seconds = 12.0;
    let body = Body::black_porgy();
    // The smooth curves: the same body with many short segments (Fig. 5 weights along it).
    let fine = Body::evenly_spaced(FINE_SEGMENTS);
    let rec = record_preset(preset, &body, seconds, RATE_HZ)?;
    let fine_rec = record_preset(preset, &fine, seconds, RATE_HZ)?;
    let (start, end) = window(&rec, preset);

    let area = BitMapBackend::new(out, size).into_drawing_area();
    area.fill(&WHITE).map_err(plot_err)?;
    let header_px = if text { 44 } else { 8 };
    let (header, panels) = area.split_vertically(header_px);
    if text {
        let kind = match preset.turn {
            Some(kind) if preset.d != 0 => kind.name().replace('_', " "),
            _ => "swim".to_owned(),
        };
        let mut title = format!(
            "{} ({kind}): p = {:.2}, s = {}, l = {}",
            preset.name, p.p, p.s, p.l
        );
        if preset.turn.is_some() && preset.d != 0 {
            title += &format!(
                ", d = {}, Tt = {} s, f = {}, angle = {:.0}°",
                preset.d,
                p.tt,
                p.f,
                p.turn_angle.to_degrees()
            );
        }
        header
            .draw(&Text::new(
                title,
                (16, 10),
                ("sans-serif", 24).into_font().color(&BLACK),
            ))
            .map_err(plot_err)?;
    }
    let (left, right) = panels.split_horizontally(size.0 / 2);
    draw_midlines(&left, preset, &fine_rec, &rec, (start, end), text)?;
    draw_from_above(&right, preset, &rec, &body, (start, end), text)?;
    area.present().map_err(|e| PlotError::write(out, e))?;
    Ok(())
}

/// Left panel: the body midline in the fish's own frame at successive instants (Fig. 4, 6).
fn draw_midlines(
    area: &DrawingArea<BitMapBackend<'_>, Shift>,
    preset: &Preset,
    fine: &Recording,
    coarse: &Recording,
    (start, end): (usize, usize),
    text: bool,
) -> Result<(), PlotError> {
    let p = preset.params;
    let turn = preset.turn.is_some() && preset.d != 0;
    // Over one tail-beat cycle for a swim, over the whole turn for a turn.
    let (from, to) = if turn {
        (start, end)
    } else {
        let cycle = (RATE_HZ / p.tail_beat_hz(p.s).max(0.1)) as usize;
        (start, (start + cycle).min(fine.frames.len() - 1))
    };
    let snapshots = if turn { 12 } else { 10 };
    let y_max = coarse.frames[from..=to]
        .iter()
        .chain(fine.frames[from..=to].iter())
        .flat_map(|f| f.lateral.iter().chain(std::iter::once(&f.head_lateral)))
        .fold(0.0f32, |m, v| m.max(v.abs()))
        / p.l;
    let y_max = (y_max * 1.15).max(0.12);
    let caption = if turn {
        "midline during the turn (dots: driven joints; dashed: envelope ±|A_f|, ±|A|)"
    } else {
        "midline over one tail beat (dots: driven joints; dashed: envelope ±|A_f|, ±|A|)"
    };
    let mut builder = ChartBuilder::on(area);
    builder.margin(14);
    if text {
        builder
            .caption(caption, ("sans-serif", 18))
            .x_label_area_size(40)
            .y_label_area_size(56);
    }
    let mut chart = builder
        .build_cartesian_2d(-0.02f32..1.02f32, -y_max..y_max)
        .map_err(plot_err)?;
    if text {
        chart
            .configure_mesh()
            .x_desc("position along the body, head (0) → tail (1), body lengths")
            .y_desc("sideways displacement (+ = fish's left), body lengths")
            .light_line_style(WHITE.mix(0.0))
            .draw()
            .map_err(plot_err)?;
    }
    // Amplitude envelope of the swim wave (±|A_f(x)| ahead of the pivot, ±|A(x)| behind it)
    // and the pivot.
    let envelope = |sign: f32| {
        (0..=100).map(move |i| {
            let x = i as f32 / 100.0;
            let a = wave::swim_amplitude(x * p.l, p.p, p.l, p.max_amp, (p.front_amp, p.front_wave));
            (x, sign * a.abs() / p.l)
        })
    };
    let grey = RGBColor(150, 150, 150);
    for sign in [-1.0, 1.0] {
        chart
            .draw_series(DashedLineSeries::new(
                envelope(sign),
                6,
                4,
                grey.stroke_width(1),
            ))
            .map_err(plot_err)?;
    }
    chart
        .draw_series(LineSeries::new(
            [(p.p, -y_max), (p.p, y_max)],
            grey.stroke_width(2),
        ))
        .map_err(plot_err)?;
    chart
        .draw_series(LineSeries::new([(0.0, 0.0), (1.0, 0.0)], grey.mix(0.5)))
        .map_err(plot_err)?;
    if text {
        chart
            .draw_series(std::iter::once(Text::new(
                "pivot p",
                (p.p + 0.01, y_max * 0.9),
                ("sans-serif", 15).into_font().color(&grey),
            )))
            .map_err(plot_err)?;
    }
    for k in 0..snapshots {
        let i = from + (to - from) * k / snapshots.max(1);
        let u = k as f32 / (snapshots - 1).max(1) as f32;
        let color = time_color(u);
        let f = &fine.frames[i];
        let curve = std::iter::once((0.0, f.head_lateral / p.l)).chain(
            fine.joints_x
                .iter()
                .zip(f.lateral.iter())
                .map(|(&x, &lat)| (x, lat / p.l)),
        );
        chart
            .draw_series(LineSeries::new(curve, color.stroke_width(2)))
            .map_err(plot_err)?;
        // The six driven joints of the skeleton on the curve.
        let c = &coarse.frames[i];
        chart
            .draw_series(
                coarse.joints_x[..coarse.joints_x.len() - 1]
                    .iter()
                    .zip(c.lateral.iter())
                    .map(|(&x, &lat)| Circle::new((x, lat / p.l), 3, color.filled())),
            )
            .map_err(plot_err)?;
    }
    Ok(())
}

/// Right panel: the posed body seen from above at successive instants along its path
/// (Fig. 7–9). Screen right is world +x, screen up is world −z, so a left turn curves up.
fn draw_from_above(
    area: &DrawingArea<BitMapBackend<'_>, Shift>,
    preset: &Preset,
    rec: &Recording,
    body: &Body,
    (start, end): (usize, usize),
    text: bool,
) -> Result<(), PlotError> {
    let p = preset.params;
    let turn = preset.turn.is_some() && preset.d != 0;
    let snapshots = if turn { 12usize } else { 9 };
    // A straight swim would draw every body on top of the last: stack them like a film strip.
    let strip_offset = if turn { 0.0 } else { -0.3 };
    let mut bodies: Vec<(f32, Vec<(f32, f32)>)> = Vec::with_capacity(snapshots);
    let mut points = vec![Vec3::ZERO; body.joints_x.len() + 1];
    for k in 0..snapshots {
        let i = start + (end - start) * k / (snapshots - 1);
        let f = &rec.frames[i];
        MidlinePoseJob {
            root: &f.root,
            body,
            l: p.l,
            head_lateral: f.head_lateral,
            head_yaw: f.head_yaw,
            yaw: &f.yaw,
            points: &mut points,
        }
        .run()?;
        let u = k as f32 / (snapshots - 1) as f32;
        let dy = strip_offset * k as f32;
        bodies.push((
            u,
            points
                .iter()
                .map(|q| (q.x / p.l, -q.z / p.l + dy))
                .collect(),
        ));
    }
    let path: Vec<(f32, f32)> = if turn {
        rec.frames[start..=end]
            .iter()
            .map(|f| (f.root.pos.x / p.l, -f.root.pos.z / p.l))
            .collect()
    } else {
        // The heads' track down the strip.
        bodies.iter().map(|(_, b)| b[0]).collect()
    };
    // Bounds with equal scale on both axes.
    let (mut x0, mut x1, mut y0, mut y1) = (f32::MAX, f32::MIN, f32::MAX, f32::MIN);
    for &(x, y) in bodies.iter().flat_map(|(_, b)| b.iter()).chain(path.iter()) {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    let pad = 0.3;
    let (x0, x1, y0, y1) = (x0 - pad, x1 + pad, y0 - pad, y1 + pad);
    let (w, h) = area.dim_in_pixel();
    let (label_w, label_h) = if text {
        (56.0, 40.0 + 30.0)
    } else {
        (0.0, 0.0)
    };
    let aspect = (w as f32 - 28.0 - label_w) / (h as f32 - 28.0 - label_h);
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    let (mut half_w, mut half_h) = (0.5 * (x1 - x0), 0.5 * (y1 - y0));
    if half_w / half_h < aspect {
        half_w = half_h * aspect;
    } else {
        half_h = half_w / aspect;
    }
    let mut builder = ChartBuilder::on(area);
    builder.margin(14);
    if text {
        builder
            .caption(
                if turn {
                    "seen from above along the path (blue → red = time)"
                } else {
                    "seen from above, successive instants stacked 0.3 body lengths apart"
                },
                ("sans-serif", 18),
            )
            .x_label_area_size(40)
            .y_label_area_size(56);
    }
    let mut chart = builder
        .build_cartesian_2d(cx - half_w..cx + half_w, cy - half_h..cy + half_h)
        .map_err(plot_err)?;
    if text {
        chart
            .configure_mesh()
            .x_desc("world x, body lengths")
            .y_desc(if turn {
                "world −z, body lengths"
            } else {
                "world −z (shifted per instant), body lengths"
            })
            .light_line_style(WHITE.mix(0.0))
            .draw()
            .map_err(plot_err)?;
    }
    chart
        .draw_series(LineSeries::new(
            path,
            RGBColor(120, 120, 120).stroke_width(1),
        ))
        .map_err(plot_err)?;
    for (u, pts) in &bodies {
        let color = time_color(*u);
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), color.stroke_width(3)))
            .map_err(plot_err)?;
        // The head as a filled dot, so the direction of travel reads at a glance.
        chart
            .draw_series(std::iter::once(Circle::new(pts[0], 5, color.filled())))
            .map_err(plot_err)?;
    }
    Ok(())
}
