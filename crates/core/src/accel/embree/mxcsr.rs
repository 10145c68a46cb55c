//! Flush-to-zero (FTZ) and denormals-are-zero (DAZ): the SSE control bits
//! Embree asks every thread that calls it to set ("This can have a severe
//! performance impact", its verbose start-up warns otherwise). Denormal
//! floats (below 1.2·10⁻³⁸) take a slow microcode path on x86; with FTZ/DAZ
//! they are treated as, and rounded to, zero.
//!
//! [`EmbreeAccel`](super::EmbreeAccel) does not rely on the caller: it turns
//! the bits on around each Embree call with [`FtzDazScope`] and restores the
//! caller's state right after, so raylab's own arithmetic keeps IEEE
//! denormals (and Rust's assumption of the default floating-point
//! environment holds in Rust code). The two control-register writes per
//! call are not free: on the camel (20k triangles) they cost ~10 % of a
//! ray's time. [`enable_ftz_daz`] sets the bits for the rest of a thread's
//! life instead (the scope then finds them set and writes nothing), e.g. in
//! a rayon pool's start handler, at the price of flushing denormals in
//! raylab's own arithmetic on that thread too:
//!
//! ```no_run
//! let pool = rayon::ThreadPoolBuilder::new()
//!     .start_handler(|_| raylab::accel::embree::enable_ftz_daz())
//!     .build()
//!     .unwrap();
//! ```
//!
//! The register is read and written with `stmxcsr`/`ldmxcsr` in inline
//! assembly (the `_mm_getcsr`/`_mm_setcsr` intrinsics do the same but are
//! deprecated). On other architectures every function here does nothing.

/// MXCSR bit 6: treat denormal inputs as zero.
const DAZ: u32 = 1 << 6;
/// MXCSR bit 15: flush denormal results to zero.
const FTZ: u32 = 1 << 15;
const FTZ_DAZ: u32 = FTZ | DAZ;

#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn read_mxcsr() -> u32 {
    let mut csr = 0u32;
    // SAFETY: stmxcsr stores the 4-byte control register at the given
    // address, which points to a live, writable u32.
    unsafe {
        std::arch::asm!(
            "stmxcsr [{}]",
            in(reg) &mut csr as *mut u32,
            options(nostack, preserves_flags)
        );
    }
    csr
}

#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn write_mxcsr(csr: u32) {
    // SAFETY: ldmxcsr loads the control register from a live u32. Only the
    // FTZ/DAZ bits are ever changed from a value read by `read_mxcsr`, so no
    // reserved bit is set (that would fault).
    unsafe {
        std::arch::asm!(
            "ldmxcsr [{}]",
            in(reg) &csr as *const u32,
            options(nostack, preserves_flags, readonly)
        );
    }
}

/// Turn on flush-to-zero and denormals-are-zero for the calling thread, for
/// good. Call it first thing in every thread that traces with Embree (see
/// the module docs for a rayon start handler). All float arithmetic of the
/// thread is affected, raylab's included: results below 1.2·10⁻³⁸ become
/// zero. Not needed for correctness: [`EmbreeAccel`](super::EmbreeAccel)
/// sets the bits around its own calls anyway.
pub fn enable_ftz_daz() {
    #[cfg(target_arch = "x86_64")]
    {
        let csr = read_mxcsr();
        if csr & FTZ_DAZ != FTZ_DAZ {
            write_mxcsr(csr | FTZ_DAZ);
        }
    }
}

/// Whether both FTZ and DAZ are on in the calling thread (always `false`
/// off x86-64).
pub fn ftz_daz_enabled() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        read_mxcsr() & FTZ_DAZ == FTZ_DAZ
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// FTZ/DAZ on for as long as the value lives, then the thread's previous
/// control state back. Costs one register read when the bits are already on
/// and two writes more when they are not. Keep the scope tight around the
/// foreign call: no Rust float arithmetic should run inside it.
#[must_use = "FTZ/DAZ are switched back off when the scope is dropped"]
pub(crate) struct FtzDazScope {
    /// The register as found, when it had to be changed.
    #[cfg(target_arch = "x86_64")]
    saved: Option<u32>,
}

impl FtzDazScope {
    #[inline(always)]
    pub(crate) fn new() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            let csr = read_mxcsr();
            if csr & FTZ_DAZ == FTZ_DAZ {
                Self { saved: None }
            } else {
                write_mxcsr(csr | FTZ_DAZ);
                Self { saved: Some(csr) }
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            Self {}
        }
    }
}

impl Drop for FtzDazScope {
    #[inline(always)]
    fn drop(&mut self) {
        #[cfg(target_arch = "x86_64")]
        if let Some(csr) = self.saved {
            write_mxcsr(csr);
        }
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;

    /// Tests run on threads of the harness's pool: run each check on a
    /// fresh thread so no state leaks into other tests.
    fn on_fresh_thread(f: impl FnOnce() + Send + 'static) {
        std::thread::spawn(f).join().unwrap();
    }

    #[test]
    fn scope_sets_and_restores() {
        on_fresh_thread(|| {
            assert!(
                !ftz_daz_enabled(),
                "a new thread starts with IEEE denormals"
            );
            {
                let _scope = FtzDazScope::new();
                assert!(ftz_daz_enabled());
            }
            assert!(!ftz_daz_enabled());
        });
    }

    #[test]
    fn enable_flushes_denormals_for_the_thread() {
        on_fresh_thread(|| {
            // black_box keeps the compiler from folding the product at
            // compile time, where the register has no say.
            let tiny = std::hint::black_box(f32::MIN_POSITIVE);
            assert!(
                std::hint::black_box(tiny * 0.5) > 0.0,
                "denormal result kept"
            );
            enable_ftz_daz();
            assert!(ftz_daz_enabled());
            assert_eq!(std::hint::black_box(tiny * 0.5), 0.0, "denormal flushed");
            // A scope inside an enabled thread leaves the bits on.
            drop(FtzDazScope::new());
            assert!(ftz_daz_enabled());
        });
    }
}
