//! Analysis of what rendering produced: image-comparison metrics (MSE,
//! relMSE, PSNR, NVIDIA's ꟻLIP), spectra (sampling-pattern periodograms,
//! image power spectra) and paper-quality plots written as PNG and SVG.
//! This is the last stage of the data flow: it reads images and numbers
//! that the film, the statistics counters and the experiments wrote, and
//! turns them into tables and figures.

pub mod metrics;
pub mod plot;
pub mod spectrum;

pub use metrics::{compare, diff_files, FlipStats, ImageMetrics, MetricsError};
