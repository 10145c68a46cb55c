//! The GPU port's integration tests (one binary): images, counters and
//! first hits against the CPU's.

mod gpu;
