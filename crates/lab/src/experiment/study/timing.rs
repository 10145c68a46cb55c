//! Timing of repeated measurements: [`Timings`] (wall-clock and process
//! CPU time of each repeat after untimed warm-ups), [`median`] and
//! [`process_cpu_seconds`].

use std::hint::black_box;
use std::time::Instant;

/// Times of repeated runs of one measurement: wall-clock time, which is
/// what a user waits (and what S1 reported), and the CPU time of the whole
/// process (every thread), which other programs on a shared machine
/// disturb far less: they can delay our threads but not add to their CPU
/// time. CPU time includes the few microseconds rayon's idle workers spin
/// before they sleep.
#[derive(Clone, Debug, PartialEq)]
pub struct Timings {
    /// Wall-clock seconds, one per repeat, in the order run.
    pub seconds: Vec<f64>,
    /// Process CPU seconds, one per repeat (NaN where the system cannot
    /// tell).
    pub cpu_seconds: Vec<f64>,
}

impl Timings {
    /// Call `f` `warmup` times untimed (to fill caches, fault in memory and
    /// let the CPU clock settle), then `repeats` times timed. Whatever `f`
    /// returns is dropped after its clock stops, so freeing a result is
    /// not part of the time.
    // ANCHOR: measure
    pub fn measure<T>(warmup: u32, repeats: u32, mut f: impl FnMut() -> T) -> Timings {
        for _ in 0..warmup {
            black_box(f());
        }
        let mut t = Timings {
            seconds: Vec::new(),
            cpu_seconds: Vec::new(),
        };
        for _ in 0..repeats {
            let cpu = process_cpu_seconds();
            let start = Instant::now();
            let out = f();
            t.seconds.push(start.elapsed().as_secs_f64());
            t.cpu_seconds.push(process_cpu_seconds() - cpu);
            drop(black_box(out));
        }
        t
    }
    // ANCHOR_END: measure

    /// The median wall-clock time; see [`median`].
    pub fn median(&self) -> f64 {
        median(&self.seconds)
    }

    /// The median CPU time; see [`median`].
    pub fn cpu_median(&self) -> f64 {
        median(&self.cpu_seconds)
    }

    /// The shortest repeat (NaN when there are none).
    pub fn min(&self) -> f64 {
        self.seconds
            .iter()
            .copied()
            .reduce(f64::min)
            .unwrap_or(f64::NAN)
    }

    /// The longest repeat (NaN when there are none).
    pub fn max(&self) -> f64 {
        self.seconds
            .iter()
            .copied()
            .reduce(f64::max)
            .unwrap_or(f64::NAN)
    }
}

/// The median (mean of the middle two for an even count); NaN when there
/// are no values. Medians are what raylab reports: one disturbed repeat
/// (another process, a page-fault storm) does not move them.
pub fn median(values: &[f64]) -> f64 {
    let mut s = values.to_vec();
    s.sort_by(f64::total_cmp);
    match s.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => s[n / 2],
        n => 0.5 * (s[n / 2 - 1] + s[n / 2]),
    }
}

/// CPU time used so far by every thread of this process, in seconds
/// (`CLOCK_PROCESS_CPUTIME_ID`, nanosecond resolution on Linux); NaN where
/// the system cannot tell.
// ANCHOR: cpu_time
pub fn process_cpu_seconds() -> f64 {
    #[cfg(unix)]
    {
        let mut ts = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: clock_gettime only writes the timespec it is given, which
        // lives for the whole call.
        if unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) } == 0 {
            return ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9;
        }
    }
    f64::NAN
}
// ANCHOR_END: cpu_time

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_time_advances_with_work() {
        let t0 = process_cpu_seconds();
        let mut x = 0u64;
        let start = Instant::now();
        while start.elapsed().as_millis() < 20 {
            x = black_box(x.wrapping_add(1));
        }
        // 20 ms of busy looping must show as some CPU time; how much depends
        // on how often a loaded machine kept this thread off the CPU.
        assert!(process_cpu_seconds() - t0 > 0.0, "{x}");
    }

    #[test]
    fn median_of_odd_and_even_counts() {
        let t = Timings {
            seconds: vec![3.0, 1.0, 2.0],
            cpu_seconds: vec![4.0, 1.0, 2.0, 3.0],
        };
        assert_eq!((t.median(), t.min(), t.max()), (2.0, 1.0, 3.0));
        assert_eq!(t.cpu_median(), 2.5);
        assert!(median(&[]).is_nan());
    }
}
