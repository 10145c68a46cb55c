//! The laboratory's integration tests, gathered into one binary:
//! anti-aliasing studies, Embree as the oracle and its validation,
//! the flood-fill studies, the BVH ladder, image metrics and plots.
//! `fuzz.rs`, which installs a counting global allocator, is a binary of
//! its own.

mod antialias;
#[cfg(feature = "embree")]
mod embree;
mod floodfill;
#[cfg(feature = "gpu")]
mod gpu_speed;
mod ladder;
mod metrics;
mod plots;
#[cfg(feature = "embree")]
mod validate;
