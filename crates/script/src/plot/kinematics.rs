//! The figure of `shoal kinematics --plot`: a fish's measured amplitude envelope at each speed
//! over the published data, and its midlines over one tail beat.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::{PlotError, plot_err};
use shoal_core::motion::kinematics::{Measurement, Mode, Subject};

/// Published envelope curves: (label, (x, a(x)) points, colour).
type Curves = Vec<(String, Vec<(f32, f32)>, RGBColor)>;
/// Published ranges at one station: (label, x, lowest a, highest a).
type Bars = Vec<(String, f32, f32, f32)>;

/// The envelope published for `mode`, as (x, a(x)) curves and (x, lo, hi) bars, with labels.
fn published_envelope(mode: Mode) -> (Curves, Bars) {
    let mackerel: Vec<(f32, f32)> = (0..=50)
        .map(|i| {
            let x = i as f32 / 50.0;
            // The mackerel model A(z)/L = 0.02 − 0.08z + 0.16z², "experimentally determined by
            // Videler and Hess" (1984) per the FILM fish-model notebook (second-hand; the
            // sources in docs/motion.md).
            (x, 0.02 - 0.08 * x + 0.16 * x * x)
        })
        .collect();
    let grey = RGBColor(150, 150, 150);
    match mode {
        Mode::Carangiform => (
            vec![(
                "mackerel model after Videler & Hess 1984 (second-hand)".to_owned(),
                mackerel,
                BLACK,
            )],
            vec![
                (
                    "bass snout, Jayne & Lauder 1995".to_owned(),
                    0.0,
                    0.004,
                    0.012,
                ),
                (
                    "bass tail tip, Jayne & Lauder 1995".to_owned(),
                    1.0,
                    0.053,
                    0.066,
                ),
            ],
        ),
        Mode::Anguilliform => (
            vec![(
                "carangiform for contrast: mackerel model (second-hand)".to_owned(),
                mackerel,
                grey,
            )],
            vec![(
                "eel tail tip: 0.08 L Gillis 1998, 0.075 L D'Août & Aerts 1999 (abstracts)"
                    .to_owned(),
                1.0,
                0.075,
                0.085,
            )],
        ),
    }
}

/// Draws the envelope (each speed, with published data) and the midlines over one beat.
pub fn plot(subject: &Subject, ms: &[Measurement], out: &Path) -> Result<(), PlotError> {
    let area = BitMapBackend::new(out, (1400, 650)).into_drawing_area();
    area.fill(&WHITE).map_err(plot_err)?;
    let (header, panels) = area.split_vertically(44);
    header
        .draw(&Text::new(
            format!(
                "{}: measured amplitude envelope and midlines ({} reference data)",
                subject.name,
                match subject.mode {
                    Mode::Carangiform => "carangiform",
                    Mode::Anguilliform => "anguilliform",
                }
            ),
            (16, 10),
            ("sans-serif", 24).into_font().color(&BLACK),
        ))
        .map_err(plot_err)?;
    let (left, right) = panels.split_horizontally(700);
    let y_max = ms
        .iter()
        .flat_map(|m| m.kinematics.envelope.iter().map(|p| p.amplitude))
        .fold(0.12f32, f32::max)
        * 1.1;
    draw_envelope(&left, subject, ms, y_max)?;
    draw_midlines(&right, ms, y_max)?;
    area.present().map_err(|e| PlotError::write(out, e))?;
    Ok(())
}

/// The left panel: the measured amplitude envelope at each speed over the published data.
fn draw_envelope(
    area: &DrawingArea<BitMapBackend<'_>, Shift>,
    subject: &Subject,
    ms: &[Measurement],
    y_max: f32,
) -> Result<(), PlotError> {
    let mut chart = ChartBuilder::on(area)
        .margin(14)
        .caption(
            "amplitude envelope a(x), half peak-to-peak",
            ("sans-serif", 18),
        )
        .x_label_area_size(40)
        .y_label_area_size(56)
        .build_cartesian_2d(0f32..1.02f32, 0f32..y_max)
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .x_desc("position along the body, snout (0) → tail tip (1), L")
        .y_desc("amplitude, body lengths")
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(plot_err)?;
    let (curves, bars) = published_envelope(subject.mode);
    // The anguilliform plot shows the carangiform curve only for contrast, in grey.
    for (label, pts, curve_color) in curves {
        chart
            .draw_series(DashedLineSeries::new(
                pts,
                8,
                5,
                curve_color.stroke_width(2),
            ))
            .map_err(plot_err)?
            .label(label)
            .legend(move |(x, y)| {
                PathElement::new([(x, y), (x + 20, y)], curve_color.stroke_width(2))
            });
    }
    for (i, (label, x, lo, hi)) in bars.into_iter().enumerate() {
        let color = RGBColor(90, 90, 90);
        let x = x.clamp(0.008, 1.01);
        chart
            .draw_series(std::iter::once(PathElement::new(
                [(x, lo), (x, hi)],
                color.stroke_width(6),
            )))
            .map_err(plot_err)?
            .label(label)
            .legend(move |(px, py)| {
                PathElement::new(
                    [(px + 10, py - 6 + i as i32), (px + 10, py + 6)],
                    color.stroke_width(5),
                )
            });
    }
    let n = ms.len().max(2) as f32;
    for (i, m) in ms.iter().enumerate() {
        let color = HSLColor(0.62 * (1.0 - f64::from(i as f32 / (n - 1.0))), 0.85, 0.45);
        chart
            .draw_series(LineSeries::new(
                m.kinematics.envelope.iter().map(|p| (p.x, p.amplitude)),
                color.stroke_width(3),
            ))
            .map_err(plot_err)?
            .label(format!(
                "ours at {} L/s",
                m.requested_speed_body_lengths_per_s
            ))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], color.stroke_width(3)));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.3))
        .label_font(("sans-serif", 15))
        .draw()
        .map_err(plot_err)?;
    Ok(())
}

/// The right panel: the midline over one tail beat at the first speed, within its envelope.
fn draw_midlines(
    area: &DrawingArea<BitMapBackend<'_>, Shift>,
    ms: &[Measurement],
    y_max: f32,
) -> Result<(), PlotError> {
    let m = &ms[0];
    let s = &m.series;
    let frames = (s.rate_hz / m.kinematics.tail_beat_hz).round() as usize;
    let lat_max = y_max.max(0.12) * 1.2;
    let mut chart = ChartBuilder::on(area)
        .margin(14)
        .caption(
            format!(
                "midline over one tail beat at {:.2} L/s (blue → red = time)",
                m.requested_speed_body_lengths_per_s
            ),
            ("sans-serif", 18),
        )
        .x_label_area_size(40)
        .y_label_area_size(56)
        .build_cartesian_2d(0f32..1.02f32, -lat_max..lat_max)
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .x_desc("position along the body, snout (0) → tail tip (1), L")
        .y_desc("lateral displacement (+ = left), L")
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(plot_err)?;
    let snapshots = 10;
    for j in 0..snapshots {
        let k = (frames * j / snapshots).min(s.num_frames() - 1);
        let color = HSLColor(0.62 * (1.0 - j as f64 / (snapshots - 1) as f64), 0.85, 0.42);
        chart
            .draw_series(LineSeries::new(
                s.stations.iter().copied().zip(s.frame(k).iter().copied()),
                color.stroke_width(2),
            ))
            .map_err(plot_err)?;
    }
    for sign in [-1.0f32, 1.0] {
        chart
            .draw_series(DashedLineSeries::new(
                m.kinematics
                    .envelope
                    .iter()
                    .map(|p| (p.x, sign * p.amplitude)),
                6,
                4,
                RGBColor(120, 120, 120).stroke_width(1),
            ))
            .map_err(plot_err)?;
    }
    Ok(())
}

/// The figure of `shoal kinematics --midline --plot`: a measured animal's envelope (and, with
/// `compare`, a shoal species' envelope measured at the animal's speed over it), and the
/// animal's midlines over one tail beat.
pub fn plot_midline(
    name: &str,
    animal: &Measurement,
    compare: Option<(&Subject, &Measurement)>,
    out: &Path,
) -> Result<(), PlotError> {
    let area = BitMapBackend::new(out, (1400, 650)).into_drawing_area();
    area.fill(&WHITE).map_err(plot_err)?;
    let (header, panels) = area.split_vertically(44);
    header
        .draw(&Text::new(
            format!(
                "{name}: measured amplitude envelope and midlines{}",
                compare.map_or(String::new(), |(s, _)| format!(", with shoal's {}", s.name))
            ),
            (16, 10),
            ("sans-serif", 24).into_font().color(&BLACK),
        ))
        .map_err(plot_err)?;
    let (left, right) = panels.split_horizontally(700);
    let y_max = std::iter::once(animal)
        .chain(compare.map(|(_, m)| m))
        .flat_map(|m| m.kinematics.envelope.iter().map(|p| p.amplitude))
        .fold(0.05f32, f32::max)
        * 1.25;
    let mut chart = ChartBuilder::on(&left)
        .margin(14)
        .caption(
            "amplitude envelope a(x), half peak-to-peak",
            ("sans-serif", 18),
        )
        .x_label_area_size(40)
        .y_label_area_size(56)
        .build_cartesian_2d(0f32..1.02f32, 0f32..y_max)
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .x_desc("position along the body, head (0) → tail tip (1), L")
        .y_desc("amplitude, body lengths")
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(plot_err)?;
    let k = &animal.kinematics;
    chart
        .draw_series(LineSeries::new(
            k.envelope.iter().map(|p| (p.x, p.amplitude)),
            BLACK.stroke_width(3),
        ))
        .map_err(plot_err)?
        .label(format!(
            "{name} (measured) at {:.2} L/s, f = {:.2} Hz",
            k.speed_body_lengths_per_s, k.tail_beat_hz
        ))
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK.stroke_width(3)));
    chart
        .draw_series(
            k.envelope
                .iter()
                .map(|p| Circle::new((p.x, p.amplitude), 4, BLACK.filled())),
        )
        .map_err(plot_err)?;
    if let Some((subject, m)) = compare {
        let color = RGBColor(220, 60, 30);
        chart
            .draw_series(LineSeries::new(
                m.kinematics.envelope.iter().map(|p| (p.x, p.amplitude)),
                color.stroke_width(3),
            ))
            .map_err(plot_err)?
            .label(format!(
                "shoal {} at {:.2} L/s, f = {:.2} Hz",
                subject.name, m.requested_speed_body_lengths_per_s, m.kinematics.tail_beat_hz
            ))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], color.stroke_width(3)));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.3))
        .label_font(("sans-serif", 15))
        .draw()
        .map_err(plot_err)?;
    draw_midlines(&right, std::slice::from_ref(animal), y_max)?;
    area.present().map_err(|e| PlotError::write(out, e))?;
    Ok(())
}
