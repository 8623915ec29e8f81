//! Figures drawn with plotters, and the helpers every figure of shoal shares: whether text can
//! be drawn here, the tank seen from above, and one error type.
//!
//! The figures themselves: [`motion`] (`shoal plot`), [`kinematics`] (`shoal kinematics
//! --plot`); the behaviour-test trace (`crate::testing::trace`), a recording's and a diff's
//! paths (`crate::timeline::plot`) and `shoal compare --plot` (`crate::timeline::compare_plot`)
//! draw beside the data they show, with these helpers.

pub mod kinematics;
pub mod motion;

use std::path::{Path, PathBuf};

use plotters::coord::types::RangedCoordf32;
use plotters::prelude::*;

/// Why a figure could not be drawn or written.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// plotters failed while drawing.
    #[error("drawing failed: {0}")]
    Draw(String),
    /// The PNG could not be written.
    #[error("writing {path}: {why}")]
    Write {
        /// The PNG asked for.
        path: PathBuf,
        /// What went wrong.
        why: String,
    },
    /// The motion to draw could not be played.
    #[error(transparent)]
    Motion(#[from] shoal_core::motion::MotionError),
    /// Drawing a figure into its PNG, or writing it, failed.
    #[error("{}: {source}", path.display())]
    Figure {
        /// The PNG.
        path: PathBuf,
        /// plotters' error.
        source: Box<dyn std::error::Error + Send + Sync>,
    },
}

impl PlotError {
    /// Writing `path` failed with `e`.
    pub(crate) fn write(path: &Path, e: impl std::fmt::Display) -> Self {
        Self::Write {
            path: path.to_path_buf(),
            why: e.to_string(),
        }
    }
}

impl PlotError {
    /// Drawing into or writing `path` failed with plotters' error `e`.
    pub(crate) fn figure(path: &Path, e: impl std::error::Error + Send + Sync + 'static) -> Self {
        Self::Figure {
            path: path.to_path_buf(),
            source: Box::new(e),
        }
    }
}

/// A plotters error as a [`PlotError`].
pub(crate) fn plot_err<E: std::fmt::Debug>(e: E) -> PlotError {
    PlotError::Draw(format!("{e:?}"))
}

/// Whether plotters can render text with a system font here (its `ttf` feature needs one).
/// Figures are drawn without captions, labels and titles where it cannot, rather than failing.
pub fn fonts_work() -> bool {
    let mut buffer = vec![0u8; 64 * 32 * 3];
    let area = BitMapBackend::with_buffer(&mut buffer, (64, 32)).into_drawing_area();
    area.draw(&Text::new("Ag", (2, 2), ("sans-serif", 14).into_font()))
        .is_ok()
}

/// The axes of a tank seen from above (x across, z down the page, whole world units), as the
/// trace and the run-diff plots draw them.
pub fn top_view_axes<DB: DrawingBackend>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf32, RangedCoordf32>>,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    chart
        .configure_mesh()
        .x_desc("x, world units")
        .y_desc("z, world units")
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_label_formatter(&|v| format!("{v:.0}"))
        .light_line_style(RGBColor(235, 235, 235))
        .bold_line_style(RGBColor(205, 205, 205))
        .draw()
}
