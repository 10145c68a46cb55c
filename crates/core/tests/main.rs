//! The renderer core's integration tests, gathered into one binary (one
//! link instead of one per file): accelerators against brute force and
//! each other, renders, the path tracer's estimators, derivatives and the
//! boundary term, the readers on real and broken files. `soak.rs`, which
//! watches its own process's memory, is a binary of its own.

mod accel;
mod boundary;
mod floodfill_render;
mod grad;
#[cfg(feature = "obvhs")]
mod obvhs;
mod params;
mod path;
mod readers;
mod render;
