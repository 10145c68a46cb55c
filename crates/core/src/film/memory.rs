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

/// What a render of `width × height` pixels holds: per pixel its running
/// statistics, the developed linear image twice (the film's and the
/// writer's copy) and an 8-bit one; with a filter wider than the box,
/// every sample's position and value ([`FilmSample`]) and the filtered
/// image.
pub fn render_bytes(width: u32, height: u32, spp: u32, keep_samples: bool) -> u128 {
    let pixels = u128::from(width) * u128::from(height);
    let per_pixel = size_of::<PixelStats>() + 2 * 3 * size_of::<f32>() + 3;
    let samples = if keep_samples {
        u128::from(spp) * size_of::<FilmSample>() as u128 + 3 * size_of::<f32>() as u128
    } else {
        0
    };
    pixels * (per_pixel as u128 + samples)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_issue_s_image_is_refused_with_its_size() {
        let needed = render_bytes(100_000, 100_000, 1, false);
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
