//! A counting global allocator: it wraps the system allocator and keeps the
//! bytes currently allocated and the peak since the last [`reset_peak`], so
//! the harness can measure what one input cost in memory.
//!
//! It also refuses to let a single request beyond [`HARD_CAP`] reach the
//! system: such a request (a `Vec::with_capacity` from an inflated count)
//! is the bug the memory check is there to find, and trying it could take
//! the machine down or abort without saying which input did it. Since a
//! global allocator must not unwind, it saves the input being run (see
//! [`super::harness::save_current_and_abort`]) and aborts the process with
//! a message naming the request and the saved file.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};

/// The largest single allocation the harness lets through: 1 GiB. No input
/// of ours is near a size that justifies it (the largest seed is 4 MB).
/// `RAYLAB_FUZZ_HARD_CAP=BYTES` lowers it, to get the backtrace of a big
/// allocation that stayed under the cap.
pub const HARD_CAP: usize = 1 << 30;

static CAP: AtomicUsize = AtomicUsize::new(HARD_CAP);

/// Set the cap (see [`HARD_CAP`]).
pub fn set_cap(bytes: usize) {
    CAP.store(bytes, Relaxed);
}

static CURRENT: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

/// The allocator; `crates/lab/tests/fuzz.rs` installs it with `#[global_allocator]`.
pub struct Counting;

fn grow(n: usize) {
    let now = CURRENT.fetch_add(n, Relaxed) + n;
    PEAK.fetch_max(now, Relaxed);
}

fn shrink(n: usize) {
    CURRENT.fetch_sub(n, Relaxed);
}

fn check(size: usize) {
    let cap = CAP.load(Relaxed);
    if size > cap {
        // Once only: what follows allocates (small amounts) itself.
        CAP.store(usize::MAX, Relaxed);
        super::harness::save_current_and_abort(&format!(
            "an allocation of {size} bytes was requested (more than the harness's \
             cap of {cap}): a size taken from the input without bounding it\n{}",
            std::backtrace::Backtrace::force_capture()
        ));
    }
}

// SAFETY: every method forwards to `System` with the caller's layout and
// pointer unchanged, so the blocks handed out are `System`'s and meet
// `GlobalAlloc`'s contract as its do; the counters are only bookkeeping
// (atomics, no allocation). None unwinds: `check` aborts instead of
// panicking.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        check(layout.size());
        // SAFETY: the caller's contract (a layout of non-zero size) is
        // `System.alloc`'s, passed on unchanged.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            grow(layout.size());
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        check(layout.size());
        // SAFETY: as in `alloc`.
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            grow(layout.size());
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: the caller's contract: `ptr` was allocated by this
        // allocator, so by `System` (every method forwards to it), with
        // `layout`.
        unsafe { System.dealloc(ptr, layout) };
        shrink(layout.size());
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        check(new_size);
        // SAFETY: the caller's contract, as for `dealloc`, and a
        // `new_size` that is non-zero and valid with `layout`'s alignment.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            // Count the new block before releasing the old one: a moving
            // realloc briefly holds both.
            grow(new_size);
            shrink(layout.size());
        }
        p
    }
}

/// Bytes allocated now.
pub fn current() -> usize {
    CURRENT.load(Relaxed)
}

/// Start a new peak measurement at the current level; returns that level.
pub fn reset_peak() -> usize {
    let now = CURRENT.load(Relaxed);
    PEAK.store(now, Relaxed);
    now
}

/// The highest level since the last [`reset_peak`].
pub fn peak() -> usize {
    PEAK.load(Relaxed)
}
