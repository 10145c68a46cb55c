//! [`PlotError`]: why a figure could not be drawn or written. Plotting has
//! its own narrow error, apart from the lab's [`crate::Error`] (which
//! wraps it), so that the figure types can be used on their own. Part of
//! [`crate::analysis::plot`].

use super::MIN_TEXT_PX;
use raylab::io::OutputError;
use std::path::PathBuf;

/// Why a figure could not be drawn or written. Messages are whole (the
/// cause included), as the lab's errors are.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// A figure, named by its kind and title, and what went wrong with it.
    #[error("{kind} \"{title}\": {error}")]
    Figure {
        /// "line chart", "bar chart", "histogram", "heatmap" or "image
        /// grid".
        kind: &'static str,
        /// Its title.
        title: String,
        /// What went wrong.
        error: Box<PlotError>,
    },
    /// Data or settings that cannot be drawn as given (a log axis without
    /// a positive value, a size out of range, images of different sizes
    /// in one grid); the message says what to change.
    #[error("{0}")]
    Invalid(String),
    /// A title, label or caption wider than its room even at the smallest
    /// text size.
    #[error(
        "the {what} \"{text}\" does not fit: {width:.0} px wide at the smallest \
         text size ({} px), {room:.0} px available; shorten it",
        MIN_TEXT_PX
    )]
    TextDoesNotFit {
        /// What the text is ("title", "x axis label"…).
        what: String,
        /// The text.
        text: String,
        /// Its width at the smallest size, in pixels.
        width: f64,
        /// The room it has, in pixels.
        room: f64,
    },
    /// Ink in the outermost pixels of the canvas: something drawn runs
    /// off it and is clipped.
    #[error(
        "something is drawn across the {edge} edge of the canvas and clipped \
         (a title or label too long for its place?)"
    )]
    Clipped {
        /// "left", "right", "top" or "bottom".
        edge: &'static str,
    },
    /// The bundled font could not be read.
    #[error("the bundled DejaVu Sans font could not be parsed")]
    Font,
    /// A text the font cannot measure.
    #[error("cannot measure the text \"{text}\": {reason}")]
    Measure {
        /// The text.
        text: String,
        /// The font library's reason.
        reason: String,
    },
    /// The drawing library failed (its errors are generic over the
    /// back end; their message is kept).
    #[error("plotting failed: {0}")]
    Backend(String),
    /// The PNG could not be encoded or written.
    #[error("{}: cannot write PNG: {error}", path.display())]
    Png {
        /// The file.
        path: PathBuf,
        /// The encoder's reason.
        error: image::ImageError,
    },
    /// The SVG could not be written.
    #[error("{}: cannot write SVG: {error}", path.display())]
    Svg {
        /// The file.
        path: PathBuf,
        /// The system's reason.
        error: std::io::Error,
    },
    /// A file that could not be written (nothing is left at its path).
    #[error(transparent)]
    Output(#[from] OutputError),
    /// A pixel buffer of the wrong size: a bug, described.
    #[error("{0}")]
    Internal(&'static str),
}

impl PlotError {
    /// `error` while drawing the figure of `kind` titled `title`.
    pub(super) fn figure(kind: &'static str, title: &str, error: PlotError) -> Self {
        PlotError::Figure {
            kind,
            title: title.to_string(),
            error: Box::new(error),
        }
    }
}
