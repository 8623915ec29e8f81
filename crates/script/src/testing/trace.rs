//! Trajectory traces of a behaviour test: a CSV of every fish's state per recorded tick (with its
//! motion, intention and memory) and a top view of the tank, seen from above, with axes in world
//! units, the tank outline, rocks, food, each fish's path from its start to its end marker and a
//! legend.

use std::path::{Path, PathBuf};

use glam::Vec3;
use plotters::coord::Shift;
use plotters::prelude::*;

use crate::plot::{fonts_work, top_view_axes};

/// One recorded fish state.
#[derive(Debug, Clone, PartialEq)]
pub struct Sample {
    /// Simulated seconds.
    pub t: f64,
    /// The fish (`fish.id` in the test).
    pub fish: u32,
    /// Root position, world units.
    pub pos: Vec3,
    /// Heading, radians.
    pub heading: f32,
    /// Speed, world units per second.
    pub speed: f32,
    /// The motion it is playing (`swim`, `normal_turn`, …; empty when idle).
    pub motion: String,
    /// Its behaviour's last intention: a string as it is, anything else as JSON, empty for nil.
    pub intention: String,
    /// Its `fish.memory` as JSON (keys sorted), empty before its first decision.
    pub memory: String,
}

/// Everything needed to draw a world's history.
#[derive(Debug, Clone, Default)]
pub struct Trace {
    /// Tank bounds (min, max).
    pub tank: (Vec3, Vec3),
    /// Recorded states, in time order.
    pub samples: Vec<Sample>,
    /// Legend text per fish: (`fish.id`, label).
    pub labels: Vec<(u32, String)>,
    /// Food: position and whether it was eaten.
    pub foods: Vec<(Vec3, bool)>,
    /// Obstacles (rocks): centre and radius.
    pub obstacles: Vec<(Vec3, f32)>,
}

/// Why a trace could not be written.
#[derive(Debug, thiserror::Error)]
pub enum TraceError {
    /// Creating or writing a file failed.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why it could not be written.
        source: std::io::Error,
    },
    /// The plotting backend failed.
    #[error("cannot draw {path}: {message}")]
    Plot {
        /// The image file.
        path: PathBuf,
        /// What the backend said.
        message: String,
    },
}

/// The CSV header: one column per [`Sample`] field.
pub const CSV_HEADER: [&str; 10] = [
    "t",
    "fish",
    "x",
    "y",
    "z",
    "heading",
    "speed",
    "motion",
    "intention",
    "memory",
];

/// Width of the plot's tank area, pixels.
const PLOT_PX: u32 = 720;
/// Width of the legend beside it, pixels.
const LEGEND_PX: u32 = 300;
/// Fish listed in the legend before "… and N more".
const LEGEND_FISH: usize = 16;

const BACKGROUND: RGBColor = WHITE;
const WATER: RGBColor = RGBColor(228, 240, 250);
const TANK_EDGE: RGBColor = RGBColor(20, 60, 110);
const ROCK: RGBColor = RGBColor(120, 116, 110);
const FOOD: RGBColor = RGBColor(20, 150, 40);
const INK: RGBColor = RGBColor(30, 30, 30);
/// Path colours, one per fish in turn: distinct from each other and from food, rocks and water.
const FISH_COLORS: [RGBColor; 10] = [
    RGBColor(220, 30, 60),
    RGBColor(40, 100, 200),
    RGBColor(250, 130, 0),
    RGBColor(140, 60, 170),
    RGBColor(150, 80, 30),
    RGBColor(230, 80, 200),
    RGBColor(0, 170, 190),
    RGBColor(120, 120, 0),
    RGBColor(20, 20, 90),
    RGBColor(110, 110, 110),
];

fn fish_color(i: usize) -> RGBColor {
    FISH_COLORS[i % FISH_COLORS.len()]
}

impl Trace {
    /// Writes the [`CSV_HEADER`] columns, one row per sample; memory and intention are quoted
    /// where they need it, so a spreadsheet opens the file as it is.
    pub fn write_csv(&self, path: &Path) -> Result<(), TraceError> {
        let err = |e: csv::Error| TraceError::Io {
            path: path.to_path_buf(),
            source: e.into(),
        };
        let mut out = csv::Writer::from_path(path).map_err(err)?;
        out.write_record(CSV_HEADER).map_err(err)?;
        for s in &self.samples {
            out.write_record([
                format!("{:.4}", s.t),
                s.fish.to_string(),
                s.pos.x.to_string(),
                s.pos.y.to_string(),
                s.pos.z.to_string(),
                s.heading.to_string(),
                s.speed.to_string(),
                s.motion.clone(),
                s.intention.clone(),
                s.memory.clone(),
            ])
            .map_err(err)?;
        }
        out.flush().map_err(|source| TraceError::Io {
            path: path.to_path_buf(),
            source,
        })
    }

    /// The fish in the trace, in order of their ids.
    fn fish_ids(&self) -> Vec<u32> {
        let mut ids: Vec<u32> = self.samples.iter().map(|s| s.fish).collect();
        ids.extend(self.labels.iter().map(|(id, _)| *id));
        ids.sort_unstable();
        ids.dedup();
        ids
    }

    /// Draws the top view into a PNG: x to the right and z downwards (as seen from above), both in
    /// world units; the tank's outline; rocks to scale; food (filled, or a ring once eaten); one
    /// coloured path per fish from a hollow square (start) to a filled disc (end); and a legend.
    /// Without a usable font the picture is drawn without text.
    pub fn write_top_view(&self, path: &Path) -> Result<(), TraceError> {
        let plot_err = |e: &dyn std::fmt::Display| TraceError::Plot {
            path: path.to_path_buf(),
            message: e.to_string(),
        };
        let text = fonts_work();
        let (min, max) = self.tank;
        let (w, h) = ((max.x - min.x).max(1e-3), (max.z - min.z).max(1e-3));
        let axes_px = if text { 70 } else { 10 };
        let plot_h = ((PLOT_PX as f32) * (h / w)).clamp(200.0, 1000.0) as u32;
        let size = (axes_px + PLOT_PX + LEGEND_PX, plot_h + axes_px + 50);
        let root = BitMapBackend::new(path, size).into_drawing_area();
        root.fill(&BACKGROUND).map_err(|e| plot_err(&e))?;
        let (left, legend) = root.split_horizontally(axes_px + PLOT_PX + 20);
        let ids = self.fish_ids();

        let mut builder = ChartBuilder::on(&left);
        builder.margin(16);
        if text {
            builder
                .caption(
                    "top view, seen from above (world units)",
                    ("sans-serif", 20),
                )
                .x_label_area_size(44)
                .y_label_area_size(56);
        }
        // z grows downwards, as the tank is seen from above.
        let mut chart = builder
            .build_cartesian_2d(min.x..max.x, max.z..min.z)
            .map_err(|e| plot_err(&e))?;
        chart
            .plotting_area()
            .fill(&BACKGROUND)
            .map_err(|e| plot_err(&e))?;
        if text {
            top_view_axes(&mut chart).map_err(|e| plot_err(&e))?;
        }
        let area = chart.plotting_area();
        area.draw(&Rectangle::new(
            [(min.x, min.z), (max.x, max.z)],
            WATER.mix(0.6).filled(),
        ))
        .map_err(|e| plot_err(&e))?;
        area.draw(&Rectangle::new(
            [(min.x, min.z), (max.x, max.z)],
            TANK_EDGE.stroke_width(3),
        ))
        .map_err(|e| plot_err(&e))?;
        for &(c, r) in &self.obstacles {
            let outline: Vec<(f32, f32)> = (0..48)
                .map(|i| {
                    let a = i as f32 / 48.0 * std::f32::consts::TAU;
                    (c.x + r * a.cos(), c.z + r * a.sin())
                })
                .collect();
            area.draw(&Polygon::new(outline, ROCK.filled()))
                .map_err(|e| plot_err(&e))?;
        }
        for &(p, eaten) in &self.foods {
            let style = if eaten {
                FOOD.stroke_width(2)
            } else {
                FOOD.filled()
            };
            area.draw(&Circle::new((p.x, p.z), 5, style))
                .map_err(|e| plot_err(&e))?;
        }
        for (i, &fish) in ids.iter().enumerate() {
            let points: Vec<(f32, f32)> = self
                .samples
                .iter()
                .filter(|s| s.fish == fish)
                .map(|s| (s.pos.x, s.pos.z))
                .collect();
            let c = fish_color(i);
            area.draw(&PathElement::new(points.clone(), c.stroke_width(2)))
                .map_err(|e| plot_err(&e))?;
            if let Some(&first) = points.first() {
                let marker =
                    EmptyElement::at(first) + Rectangle::new([(-6, -6), (6, 6)], c.stroke_width(2));
                area.draw(&marker).map_err(|e| plot_err(&e))?;
            }
            if let Some(&last) = points.last() {
                area.draw(&Circle::new(last, 6, c.filled()))
                    .map_err(|e| plot_err(&e))?;
            }
        }
        self.draw_legend(&legend, &ids, text)
            .map_err(|e| plot_err(&e))?;
        root.present().map_err(|e| plot_err(&e))
    }

    /// The legend: one line per fish in its colour, then the symbols.
    fn draw_legend<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        ids: &[u32],
        text: bool,
    ) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
        let font = ("sans-serif", 15).into_font().color(&INK);
        let mut y = 40;
        let row = 22;
        let label = |area: &DrawingArea<DB, Shift>, s: &str, y: i32| {
            if text {
                area.draw(&Text::new(s.to_owned(), (44, y - 8), font.clone()))
            } else {
                Ok(())
            }
        };
        for (i, &fish) in ids.iter().enumerate().take(LEGEND_FISH) {
            let c = fish_color(i);
            area.draw(&PathElement::new([(6, y), (36, y)], c.stroke_width(3)))?;
            let name = self
                .labels
                .iter()
                .find(|(id, _)| *id == fish)
                .map_or_else(|| format!("fish {fish}"), |(_, l)| l.clone());
            label(area, &name, y)?;
            y += row;
        }
        if ids.len() > LEGEND_FISH {
            label(
                area,
                &format!("… and {} more fish", ids.len() - LEGEND_FISH),
                y,
            )?;
            y += row;
        }
        y += row / 2;
        area.draw(&Rectangle::new(
            [(15, y - 6), (27, y + 6)],
            INK.stroke_width(2),
        ))?;
        label(area, "start", y)?;
        y += row;
        area.draw(&Circle::new((21, y), 6, INK.filled()))?;
        label(area, "end", y)?;
        y += row;
        area.draw(&Circle::new((21, y), 5, FOOD.filled()))?;
        label(area, "food", y)?;
        y += row;
        area.draw(&Circle::new((21, y), 5, FOOD.stroke_width(2)))?;
        label(area, "food, eaten", y)?;
        y += row;
        area.draw(&Circle::new((21, y), 8, ROCK.filled()))?;
        label(area, "rock (to scale)", y)?;
        y += row;
        area.draw(&Rectangle::new(
            [(8, y - 7), (34, y + 7)],
            TANK_EDGE.stroke_width(3),
        ))?;
        label(area, "tank walls", y)?;
        Ok(())
    }
}
