//! How far this process's renders are, for a progress bar: image rows
//! announced and rows finished, counted with two relaxed atomic adds (one
//! per row, nothing per sample, so the counters cost nothing measurable).
//! The counts only grow; a watcher takes a [`snapshot`] before a render
//! and shows the difference (`report::progress` does, on a terminal).
//! Renders running side by side in one process (tests) add to the same
//! counts: a bar then shows their sum.

use std::sync::atomic::{AtomicU64, Ordering::Relaxed};

static ANNOUNCED: AtomicU64 = AtomicU64::new(0);
static FINISHED: AtomicU64 = AtomicU64::new(0);

/// A render pass is about to trace `rows` rows.
pub fn announce(rows: u64) {
    ANNOUNCED.fetch_add(rows, Relaxed);
}

/// One row is finished.
pub fn row_done() {
    FINISHED.fetch_add(1, Relaxed);
}

/// (rows finished, rows announced) since the process started.
pub fn snapshot() -> (u64, u64) {
    (FINISHED.load(Relaxed), ANNOUNCED.load(Relaxed))
}
