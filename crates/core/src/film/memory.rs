//! Memory checked before it is asked for: an image of 100 000 × 100 000
//! pixels needs 280 GB for its film alone, and asking the allocator for it
//! aborts the process. [`check`] compares what a piece of work will hold
//! with what this machine can give it, and says both in an error;
//! [`render_bytes`] is what a render holds per image size, sampler and
//! filter.

use super::{FilmSample, PixelStats};
use std::fmt;
use std::mem::size_of;

/// Not enough memory for a piece of work.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{what} would need {} of memory, and this machine has {} available", Bytes(*.needed), Bytes(*.available))]
pub struct MemoryError {
    /// What was to be allocated, e.g. "a 100000×100000 image at 1 spp".
    pub what: String,
    /// Bytes it would need.
    pub needed: u128,
    /// Bytes available ([`available_bytes`]).
    pub available: u128,
}

/// A byte count for people: `280.0 GB`, `3.2 MB`.
#[derive(Clone, Copy, Debug)]
pub struct Bytes(pub u128);

impl fmt::Display for Bytes {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let b = self.0 as f64;
        match self.0 {
            0..1_000 => write!(f, "{} bytes", self.0),
            1_000..1_000_000 => write!(f, "{:.1} kB", b / 1e3),
            1_000_000..1_000_000_000 => write!(f, "{:.1} MB", b / 1e6),
            1_000_000_000..1_000_000_000_000 => write!(f, "{:.1} GB", b / 1e9),
            _ => write!(f, "{:.1} TB", b / 1e12),
        }
    }
}

/// The memory this process can use: the smaller of the kernel's
/// `MemAvailable` and the cgroup's `memory.max` (a container's or a Slurm
/// job's limit); unlimited where neither can be read.
pub fn available_bytes() -> u128 {
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok().and_then(|t| {
        t.lines()
            .find_map(|l| l.strip_prefix("MemAvailable:"))
            .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u128>().ok())
            .map(|kb| kb * 1024)
    });
    let cgroup = std::fs::read_to_string("/sys/fs/cgroup/memory.max")
        .ok()
        .and_then(|t| t.trim().parse::<u128>().ok());
    [meminfo, cgroup]
        .into_iter()
        .flatten()
        .min()
        .unwrap_or(u128::MAX)
}

/// Fail when `needed` bytes exceed what is available (or what an
/// allocation can ask for at all, `isize::MAX`).
pub fn check(what: impl FnOnce() -> String, needed: u128) -> Result<(), MemoryError> {
    let available = available_bytes().min(isize::MAX as u128);
    if needed > available {
        return Err(MemoryError {
            what: what(),
            needed,
            available,
        });
    }
    Ok(())
}

/// The image file a render writes, for what writing it holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutputFormat {
    /// 8-bit sRGB PNG: one byte per channel beside the linear image.
    Png,
    /// OpenEXR with the film's statistics: seven 32-bit channels (R, G, B,
    /// variance.R/G/B, count) gathered before the writer compresses them.
    Exr,
}

/// What a render holds, in the terms [`render_bytes`] counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RenderHolds {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Whether every sample is kept for a filter wider than the box.
    pub keep_samples: bool,
    pub output: OutputFormat,
    /// Worker threads.
    pub threads: usize,
}

/// What a worker thread adds once it runs: its stack and its allocator
/// arena as first touched (measured about 0.9 MB on Linux with glibc).
pub const THREAD_BYTES: u128 = 1 << 20;

/// What a render holds at its peak, beyond what the process held before
/// it: per pixel its running statistics ([`PixelStats`]), the developed
/// linear image, and what the output needs ([`OutputFormat`]); with a
/// filter wider than the box, the larger of the filter's time (every
/// sample's position and value, [`FilmSample`], with the filter's sums
/// and image) and the end's (the filtered image beside the developed
/// one); the worker threads; and the
/// EXR writer's blocks in flight (two more than threads, each 16 scan
/// lines of its channels, uncompressed and compressed). Measured against
/// the peak resident memory of `raylab render` (crates/cli/tests/memory.rs:
/// within +10 %/−0 %).
pub fn render_bytes(r: &RenderHolds) -> u128 {
    let pixels = u128::from(r.width) * u128::from(r.height);
    let stats = size_of::<PixelStats>() as u128;
    let image = 3 * size_of::<f32>() as u128;
    let channels = 7 * size_of::<f32>() as u128;
    let written = match r.output {
        OutputFormat::Png => 3,
        OutputFormat::Exr => channels,
    };
    let end = stats + image + written;
    let per_pixel = if r.keep_samples {
        // While the filter runs: the samples, its sums and its image beside
        // the statistics; a PNG's 8-bit image may be written before the
        // allocator has let the samples' memory go.
        let samples = u128::from(r.spp) * size_of::<FilmSample>() as u128;
        (stats + samples + 2 * image + 3).max(end + image)
    } else {
        end
    };
    let threads = r.threads.max(1) as u128;
    let blocks = match r.output {
        OutputFormat::Png => 0,
        OutputFormat::Exr => (threads + 2) * 2 * 16 * u128::from(r.width) * channels,
    };
    pixels * per_pixel + threads * THREAD_BYTES + blocks
}

/// What a scene holds per triangle once built, the most over the
/// accelerators: its mesh data, primitive and tree. Measured as the growth
/// of `raylab render`'s peak between procedural icospheres of 1.3 M and
/// 5.2 M triangles on one thread: `obvhs` 387 bytes a triangle, `bvh4`
/// 361, `embree` 289, `bvh2` 278, `bvh8` 239, `brute` 109.
pub const TRIANGLE_BYTES: u128 = 400;

/// This process's resident memory now (`VmRSS`), and the most it has held
/// (`VmHWM`), in bytes; `None` where /proc cannot tell.
pub fn resident_bytes() -> Option<(u128, u128)> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let field = |name: &str| {
        status
            .lines()
            .find_map(|l| l.strip_prefix(name))
            .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u128>().ok())
            .map(|kb| kb * 1024)
    };
    Some((field("VmRSS:")?, field("VmHWM:")?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_issue_s_image_is_refused_with_its_size() {
        let needed = render_bytes(&RenderHolds {
            width: 100_000,
            height: 100_000,
            spp: 1,
            keep_samples: false,
            output: OutputFormat::Png,
            threads: 1,
        });
        assert!(needed >= 280_000_000_000);
        let e = check(|| "a 100000×100000 image".into(), needed).unwrap_err();
        let text = e.to_string();
        assert!(
            text.starts_with("a 100000×100000 image would need"),
            "{text}"
        );
        assert!(
            text.contains(" GB of memory") || text.contains(" TB of memory"),
            "{text}"
        );
        assert!(check(|| unreachable!(), 1 << 20).is_ok());
    }

    #[test]
    fn bytes_print_in_decimal_units() {
        assert_eq!(Bytes(999).to_string(), "999 bytes");
        assert_eq!(Bytes(280_000_000_000).to_string(), "280.0 GB");
        assert_eq!(Bytes(3_200_000).to_string(), "3.2 MB");
    }
}
