//! Accelerators: given the scene's bounded primitives, find the closest hit
//! along a ray (`intersect`) or whether anything blocks a segment
//! (`occluded`, any-hit, used by shadow rays). All accelerators share one
//! trait so a scene can switch by name; the [`Accelerator`] enum dispatches
//! once per ray, never per primitive test.

pub mod brute;

pub use brute::Brute;

use crate::shape::{PreparedRay, PrimHit, Primitive};
use crate::stats::Stats;
use std::fmt;
use std::str::FromStr;

/// The query interface every accelerator implements. `prims` is the scene's
/// full primitive list; an accelerator only ever looks at the bounded ones
/// it was built over.
pub trait Accel: Send + Sync {
    /// Closest hit with t in (0, t_max): (primitive index, hit).
    fn intersect<S: Stats>(
        &self,
        prims: &[Primitive],
        ray: &PreparedRay,
        t_max: f32,
        stats: &mut S,
    ) -> Option<(u32, PrimHit)>;

    /// Whether any primitive is hit with t in (0, t_max). May stop at the
    /// first hit found.
    fn occluded<S: Stats>(
        &self,
        prims: &[Primitive],
        ray: &PreparedRay,
        t_max: f32,
        stats: &mut S,
    ) -> bool;
}

/// Accelerators selectable by name (`--accel`, `accel = "…"` in a scene).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum AccelKind {
    /// Test every primitive.
    #[default]
    Brute,
}

impl FromStr for AccelKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "brute" => Ok(AccelKind::Brute),
            _ => Err(format!("unknown accelerator `{s}` (expected `brute`)")),
        }
    }
}

impl fmt::Display for AccelKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AccelKind::Brute => write!(f, "brute"),
        }
    }
}

/// A built accelerator of any kind.
#[derive(Clone, Debug)]
pub enum Accelerator {
    Brute(Brute),
}

impl Accelerator {
    /// Build an accelerator of `kind` over the primitives `bounded` (indices
    /// into `prims`).
    pub fn build(kind: AccelKind, prims: &[Primitive], bounded: Vec<u32>) -> Self {
        let _ = prims;
        match kind {
            AccelKind::Brute => Accelerator::Brute(Brute::new(bounded)),
        }
    }

    pub fn kind(&self) -> AccelKind {
        match self {
            Accelerator::Brute(_) => AccelKind::Brute,
        }
    }
}

impl Accel for Accelerator {
    #[inline]
    fn intersect<S: Stats>(
        &self,
        prims: &[Primitive],
        ray: &PreparedRay,
        t_max: f32,
        stats: &mut S,
    ) -> Option<(u32, PrimHit)> {
        match self {
            Accelerator::Brute(a) => a.intersect(prims, ray, t_max, stats),
        }
    }

    #[inline]
    fn occluded<S: Stats>(
        &self,
        prims: &[Primitive],
        ray: &PreparedRay,
        t_max: f32,
        stats: &mut S,
    ) -> bool {
        match self {
            Accelerator::Brute(a) => a.occluded(prims, ray, t_max, stats),
        }
    }
}
