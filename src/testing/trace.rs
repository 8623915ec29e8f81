//! Trajectory traces of a behaviour test: a CSV of every fish's state per recorded tick and a
//! top view (x right, z down, as seen from above) of the tank with paths, food and obstacles.

use std::io::Write;
use std::path::{Path, PathBuf};

use glam::Vec3;
use plotters::prelude::*;

/// One recorded fish state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Simulated seconds.
    pub t: f64,
    /// The fish's index in spawn order within its world.
    pub fish: u32,
    /// Root position, world units.
    pub pos: Vec3,
    /// Heading, radians.
    pub heading: f32,
    /// Speed, world units per second.
    pub speed: f32,
}

/// Everything needed to draw a world's history.
#[derive(Debug, Clone, Default)]
pub struct Trace {
    /// Tank bounds (min, max).
    pub tank: (Vec3, Vec3),
    /// Recorded states, in time order.
    pub samples: Vec<Sample>,
    /// Food: position and whether it was eaten.
    pub foods: Vec<(Vec3, bool)>,
    /// Obstacles: centre and radius.
    pub obstacles: Vec<(Vec3, f32)>,
}

/// Why a trace could not be written.
#[derive(Debug, thiserror::Error)]
pub enum TraceError {
    /// Creating or writing a file failed.
    #[error("cannot write {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    /// The plotting backend failed.
    #[error("cannot draw {path}: {message}")]
    Plot { path: PathBuf, message: String },
}

impl Trace {
    /// Writes `t,fish,x,y,z,heading,speed` rows.
    pub fn write_csv(&self, path: &Path) -> Result<(), TraceError> {
        let io = |source| TraceError::Io {
            path: path.to_path_buf(),
            source,
        };
        let mut out = std::io::BufWriter::new(std::fs::File::create(path).map_err(io)?);
        writeln!(out, "t,fish,x,y,z,heading,speed").map_err(io)?;
        for s in &self.samples {
            writeln!(
                out,
                "{:.4},{},{},{},{},{},{}",
                s.t, s.fish, s.pos.x, s.pos.y, s.pos.z, s.heading, s.speed
            )
            .map_err(io)?;
        }
        out.flush().map_err(io)
    }

    /// Draws the top view: tank outline, one coloured path per fish (a dot at its last
    /// position), food (green, hollow once eaten) and obstacles (grey discs).
    pub fn write_top_view(&self, path: &Path) -> Result<(), TraceError> {
        let plot_err = |e: &dyn std::fmt::Display| TraceError::Plot {
            path: path.to_path_buf(),
            message: e.to_string(),
        };
        let (min, max) = self.tank;
        let (w, h) = (max.x - min.x, max.z - min.z);
        let px = 640u32;
        let py = ((px as f32) * (h / w.max(1e-3))).clamp(160.0, 1280.0) as u32;
        let root = BitMapBackend::new(path, (px, py)).into_drawing_area();
        root.fill(&RGBColor(12, 40, 64)).map_err(|e| plot_err(&e))?;
        // Top view seen from above with +y up: x to the right, z towards the bottom.
        let area =
            root.apply_coord_spec(Cartesian2d::<
                plotters::coord::types::RangedCoordf32,
                plotters::coord::types::RangedCoordf32,
            >::new(
                min.x..max.x, min.z..max.z, (0..px as i32, 0..py as i32)
            ));
        area.draw(&Rectangle::new(
            [(min.x, min.z), (max.x, max.z)],
            ShapeStyle::from(&RGBColor(200, 220, 240)).stroke_width(2),
        ))
        .map_err(|e| plot_err(&e))?;
        for &(c, r) in &self.obstacles {
            let radius_px = (r / w * px as f32).max(2.0) as i32;
            area.draw(&Circle::new(
                (c.x, c.z),
                radius_px,
                ShapeStyle::from(&RGBColor(120, 120, 130)).filled(),
            ))
            .map_err(|e| plot_err(&e))?;
        }
        for &(p, eaten) in &self.foods {
            let style = if eaten {
                ShapeStyle::from(&GREEN).stroke_width(1)
            } else {
                ShapeStyle::from(&GREEN).filled()
            };
            area.draw(&Circle::new((p.x, p.z), 4, style))
                .map_err(|e| plot_err(&e))?;
        }
        let num_fish = self.samples.iter().map(|s| s.fish + 1).max().unwrap_or(0);
        for fish in 0..num_fish {
            let color = Palette99::pick(fish as usize).to_rgba();
            let points: Vec<(f32, f32)> = self
                .samples
                .iter()
                .filter(|s| s.fish == fish)
                .map(|s| (s.pos.x, s.pos.z))
                .collect();
            area.draw(&PathElement::new(points.clone(), color.stroke_width(2)))
                .map_err(|e| plot_err(&e))?;
            if let Some(&last) = points.last() {
                area.draw(&Circle::new(last, 4, color.filled()))
                    .map_err(|e| plot_err(&e))?;
            }
        }
        root.present().map_err(|e| plot_err(&e))
    }
}
