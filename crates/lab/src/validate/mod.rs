//! Validation against Embree 4 as the oracle (`raylab validate`).
//!
//! A mesh or a scene is turned into a list of bounded primitives
//! ([`Input`]); named ray sets are generated over it ([`rays`]); every ray
//! is traced by each raylab accelerator under test and by Embree, closest
//! hit and any-hit; the answers are compared and each difference
//! classified ([`compare`]); the verdicts are tallied and reported
//! ([`report`]). Embree holds its own copy of the geometry in its own
//! primitives and never calls back into raylab, so the oracle is not an
//! echo.

pub mod compare;
pub mod rays;
pub mod report;

pub use compare::{classify, Answer, Answers, HitPlace, Outcome, Verdict};
pub use rays::{RaySet, Topology};
pub use report::{Case, SetReport, Tally, ValidationReport};

use crate::Error;
use raylab::accel::embree::EmbreeAccel;
use raylab::accel::{Accel, AccelKind, Accelerator, BvhConfig, EmbreeConfig};
use raylab::camera::Camera;
use raylab::io::scene_file::{load_scene, Overrides};
use raylab::io::{read_mesh, InputError};
use raylab::math::Aabb;
use raylab::math::{rotation_xyz_degrees, Ray, SplitMix64, Vec3};
use raylab::shape::{Ellipsoid, PreparedRay, Primitive, Shape, Sphere, Triangle};
use raylab::stats::NoStats;
use rayon::prelude::*;
use std::path::Path;

/// What counts as agreement, and how much disagreement is allowed. The
/// defaults are the acceptance criteria of the Embree cross-check.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tolerances {
    /// Largest |Δt|/t for same-primitive hits beyond the grazing angle.
    /// 10⁻⁵ is ~80 ulps of f32: room for two different formulas
    /// (watertight shear test or stable quadratic, Embree's own) each
    /// rounding a handful of times, while a real mistake (wrong root,
    /// wrong primitive, wrong transform) is off by far more.
    pub t_rel: f32,
    /// Angle to the surface (degrees) below which a hit is grazing: its t
    /// is ill-conditioned and its hit/miss decided by rounding.
    pub grazing_deg: f32,
    /// Largest angle (rad) between the two sides' normals at the same
    /// point, beyond the grazing angle. 10⁻⁴: both derive normals from f32
    /// points with ~10⁻⁶ relative error; the ellipsoid instancing of
    /// Embree amplifies it by r_max/r_min and the origin's distance (see
    /// crates/lab/tests/embree.rs), still well under 10⁻⁴ for radii ratios ≤ 4.
    pub normal_angle: f32,
    /// Allowed unexplained disagreements plus tolerance breaches per set.
    pub max_unexplained: u64,
    /// Allowed edge/vertex/grazing disagreements per set (`None`: any).
    pub max_borderline: Option<u64>,
}

impl Default for Tolerances {
    fn default() -> Self {
        Self {
            t_rel: 1e-5,
            grazing_deg: 1.0,
            normal_angle: 1e-4,
            max_unexplained: 0,
            max_borderline: None,
        }
    }
}

impl Tolerances {
    /// |cos θ| (ray against normal) at the grazing angle: sin of the angle
    /// to the surface.
    pub fn grazing_cos(&self) -> f32 {
        self.grazing_deg.to_radians().sin()
    }
}

/// The geometry to validate: bounded primitives (planes are unbounded and
/// left out: Embree has no infinite plane) and the scene's camera.
#[derive(Clone, Debug)]
pub struct Input {
    /// A short name (the file name).
    pub name: String,
    pub prims: Vec<Primitive>,
    pub camera: Option<Camera>,
}

fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into(),
    )
}

impl Input {
    /// A mesh file's triangles; degenerate (zero-area) triangles are kept,
    /// since both sides must miss them.
    pub fn from_mesh(path: &Path) -> Result<Self, InputError> {
        let mesh = read_mesh(path)?;
        if mesh.triangles.is_empty() {
            return Err(InputError::file(
                path,
                "the mesh has no triangles to validate",
            ));
        }
        let prims = mesh
            .triangles
            .iter()
            .map(|t| {
                let p = t.map(|i| mesh.positions[i as usize]);
                Primitive {
                    shape: Shape::Triangle(Triangle::new(p[0], p[1], p[2])),
                    object: 0,
                }
            })
            .collect();
        Ok(Self {
            name: file_name(path),
            prims,
            camera: None,
        })
    }

    /// A scene file's bounded primitives (meshes placed by their
    /// transforms, spheres, ellipsoids) and its camera.
    pub fn from_scene(path: &Path) -> Result<Self, InputError> {
        let scene = load_scene(
            path,
            &Overrides {
                accel: Some(AccelKind::Brute),
                ..Overrides::default()
            },
        )?;
        let prims: Vec<Primitive> = scene
            .prims
            .iter()
            .filter(|p| p.bounds().is_some())
            .copied()
            .collect();
        if prims.is_empty() {
            return Err(InputError::file(
                path,
                "the scene has no bounded primitives to validate (planes are left out)",
            ));
        }
        Ok(Self {
            name: file_name(path),
            prims,
            camera: Some(scene.camera),
        })
    }

    pub fn bounds(&self) -> Aabb {
        raylab::shape::bounds_of(&self.prims)
    }

    pub fn triangle_count(&self) -> usize {
        raylab::shape::triangle_count(&self.prims)
    }
}

/// Below this many primitives brute force is among the default
/// accelerators (as in `raylab stats`): it tests every primitive, so it
/// checks the shapes without any hierarchy in the way.
pub const BRUTE_LIMIT: usize = 5000;

/// How to validate.
#[derive(Clone, Debug, PartialEq)]
pub struct ValidationOptions {
    /// Rays per set (a set may hold fewer: see [`rays::inside_mesh`]).
    pub rays: usize,
    pub seed: u64,
    /// raylab accelerators under test (empty: [`default_accels`]).
    pub accels: Vec<AccelKind>,
    pub embree: EmbreeConfig,
    pub tolerances: Tolerances,
    /// How many worst cases to keep.
    pub worst: usize,
    /// Also compare any-hit queries (two per ray and side). Off only where
    /// they would dominate the cost, as brute force over a large mesh.
    pub any_hit: bool,
}

impl Default for ValidationOptions {
    fn default() -> Self {
        Self {
            rays: 10_000,
            seed: 1,
            accels: Vec::new(),
            embree: EmbreeConfig::default(),
            tolerances: Tolerances::default(),
            worst: 10,
            any_hit: true,
        }
    }
}

/// The default accelerators for `n` primitives: brute force below
/// [`BRUTE_LIMIT`], and the fastest tree (`bvh`, that is `bvh8`).
pub fn default_accels(n: usize) -> Vec<AccelKind> {
    let mut v = Vec::new();
    if n < BRUTE_LIMIT {
        v.push(AccelKind::Brute);
    }
    v.push(AccelKind::Bvh8);
    v
}

/// The ray sets [`ray_sets`] can make.
const SETS: u128 = 8;

/// Refuse `rays` rays per set that this machine cannot hold: every set's
/// rays, one set's answers at a time, and per set and accelerator the
/// |Δt|/t and normal angles the percentiles are taken from.
fn check_memory(rays: usize, accels: usize) -> Result<(), Error> {
    let n = rays as u128;
    let needed = SETS * n * size_of::<Ray>() as u128
        + n * size_of::<Answers>() as u128
        + SETS * accels as u128 * n * 2 * size_of::<f32>() as u128;
    raylab::film::memory::check(
        || format!("--rays {rays} ({SETS} ray sets, {accels} accelerators)"),
        needed,
    )?;
    Ok(())
}

/// Generate the ray sets for an input: `random`, `surface`, `camera`,
/// `inside` (closed meshes), `edges`, `vertices`, `grazing` (triangles),
/// `inside-quadrics` (spheres and ellipsoids). Sets that do not apply are
/// left out. `first_hit` chooses interior origins (see
/// [`rays::inside_mesh`]).
pub fn ray_sets(
    input: &Input,
    topology: &Topology,
    opts: &ValidationOptions,
    first_hit: impl Fn(&Ray) -> Option<f32> + Sync,
) -> Vec<RaySet> {
    let g = rays::Geometry {
        prims: &input.prims,
        bounds: input.bounds(),
        topology,
        camera: input.camera.as_ref(),
    };
    let n = opts.rays;
    // One seed per set, so adding a set changes no other.
    let seed = |k: u64| raylab::math::SplitMix64::mix(opts.seed.wrapping_mul(16) + k);
    let sets = [
        ("random", rays::random(&g, n, seed(0))),
        ("surface", rays::surface(&g, n, seed(1))),
        ("camera", rays::camera(&g, n, seed(2))),
        ("inside", rays::inside_mesh(&g, n, seed(3), first_hit)),
        ("edges", rays::edges(&g, n, seed(4))),
        ("vertices", rays::vertices(&g, n, seed(5))),
        (
            "grazing",
            rays::grazing(&g, n, seed(6), opts.tolerances.grazing_deg),
        ),
        ("inside-quadrics", rays::inside_quadrics(&g, n, seed(7))),
    ];
    sets.into_iter()
        .filter(|(_, r)| !r.is_empty())
        .map(|(name, rays)| RaySet { name, rays })
        .collect()
}

/// Trace one ray on both sides: closest hit, and (if `any_hit`) any-hit
/// over the whole ray and up to half the nearer closest hit. Without
/// any-hit queries, the answers record what the closest hits imply, so
/// nothing is counted against them.
pub fn trace_both(
    ours: &impl Accel,
    theirs: &EmbreeAccel,
    prims: &[Primitive],
    ray: &Ray,
    any_hit: bool,
) -> Answers {
    let pr = PreparedRay::new(*ray);
    let inf = f32::INFINITY;
    let o = ours.intersect(prims, &pr, inf, &mut NoStats);
    let e = theirs.trace(ray, inf);
    let first = match (o, e) {
        (Some(o), Some(e)) => o.1.t.min(e.hit.t),
        (Some(o), None) => o.1.t,
        (None, Some(e)) => e.hit.t,
        (None, None) => inf,
    };
    let half = 0.5 * first;
    if !any_hit {
        return Answers {
            ours: o.map(|(prim, hit)| Answer { prim, hit }),
            theirs: e,
            any: (o.is_some(), e.is_some()),
            before_first: (false, false),
        };
    }
    Answers {
        ours: o.map(|(prim, hit)| Answer { prim, hit }),
        theirs: e,
        any: (
            ours.occluded(prims, &pr, inf, &mut NoStats),
            theirs.occluded(prims, &pr, inf, &mut NoStats),
        ),
        before_first: (
            ours.occluded(prims, &pr, half, &mut NoStats),
            theirs.occluded(prims, &pr, half, &mut NoStats),
        ),
    }
}

/// One ray set compared on one accelerator.
#[derive(Clone, Debug)]
pub struct SetComparison {
    /// The set's tally.
    pub report: SetReport,
    /// Its worst cases, worst first.
    pub worst: Vec<Case>,
}

/// Compare one ray set on one accelerator: the tally and the worst cases.
pub fn compare_set(
    input: &Input,
    set: &RaySet,
    accel: &Accelerator,
    embree: &EmbreeAccel,
    opts: &ValidationOptions,
) -> SetComparison {
    let tol = &opts.tolerances;
    let prims = &input.prims;
    let answers: Vec<Answers> = set
        .rays
        .par_iter()
        .map(|r| trace_both(accel, embree, prims, r, opts.any_hit))
        .collect();
    let mut tally = Tally::default();
    let mut cases = Vec::new();
    let accel_name = accel.kind().to_string();
    for (index, (ray, a)) in set.rays.iter().zip(&answers).enumerate() {
        let verdict = classify(tol, prims, ray, a);
        tally.add(&verdict, tol);
        let notable = !matches!(verdict.outcome, Outcome::BothMiss | Outcome::Agree)
            || verdict.breaks()
            || verdict.t_ratio.is_some_and(|r| r > 0.1);
        if notable {
            cases.push(Case {
                set: set.name,
                accel: accel_name.clone(),
                index,
                ray: *ray,
                answers: *a,
                verdict,
            });
        }
        // Keep the candidate list bounded on sets with many notable rays.
        if cases.len() > 4 * opts.worst.max(16) {
            keep_worst(&mut cases, opts.worst);
        }
    }
    keep_worst(&mut cases, opts.worst);
    SetComparison {
        report: SetReport {
            set: set.name,
            accel: accel_name,
            tally,
        },
        worst: cases,
    }
}

fn keep_worst(cases: &mut Vec<Case>, k: usize) {
    cases.sort_by(|a, b| {
        let (sa, sb) = (a.severity(), b.severity());
        sb.partial_cmp(&sa).unwrap_or(std::cmp::Ordering::Equal)
    });
    cases.truncate(k);
}

/// Validate an input: build Embree and each accelerator, generate the ray
/// sets, trace, compare, tally. Fails only if Embree cannot be set up.
pub fn validate(input: &Input, opts: &ValidationOptions) -> Result<ValidationReport, Error> {
    let ids: Vec<u32> = (0..input.prims.len() as u32).collect();
    let embree = EmbreeAccel::build(&input.prims, &ids, opts.embree).map_err(Error::Oracle)?;
    let kinds = if opts.accels.is_empty() {
        default_accels(input.prims.len())
    } else {
        opts.accels.clone()
    };
    let topology = Topology::of(&input.prims);
    // Interior origins are chosen with raylab's default BVH.
    let bvh = Accelerator::build(
        AccelKind::Bvh(BvhConfig::default()),
        &input.prims,
        ids.clone(),
    )
    .map_err(Error::accel(AccelKind::Bvh(BvhConfig::default())))?;
    let first_hit = |r: &Ray| {
        bvh.intersect(
            &input.prims,
            &PreparedRay::new(*r),
            f32::INFINITY,
            &mut NoStats,
        )
        .map(|(_, h)| h.t)
    };
    check_memory(opts.rays, kinds.len())?;
    let sets = ray_sets(input, &topology, opts, first_hit);
    let mut reports = Vec::new();
    let mut worst = Vec::new();
    for kind in kinds {
        let accel =
            Accelerator::build(kind, &input.prims, ids.clone()).map_err(Error::accel(kind))?;
        for set in &sets {
            let c = compare_set(input, set, &accel, &embree, opts);
            reports.push(c.report);
            worst.extend(c.worst);
        }
    }
    keep_worst(&mut worst, opts.worst);
    Ok(ValidationReport {
        input: input.name.clone(),
        primitives: input.prims.len(),
        triangles: input.triangle_count(),
        closed: topology.is_closed(),
        embree: format!("{} ({})", opts.embree, embree.version()),
        sets: reports,
        worst,
    })
}

/// `count` random spheres (radius 0.2 to 2) or rotated ellipsoids (radii
/// 0.5 to 2 each, random rotation) with centres in [−10, 10]³: they
/// overlap now and then, so rays also cross from one into another. The
/// quadric inputs of the Embree cross-checks.
pub fn random_quadrics(count: usize, seed: u64, ellipsoids: bool) -> Vec<Primitive> {
    let mut rng = SplitMix64(seed);
    let v3 = |rng: &mut SplitMix64, lo, hi| {
        Vec3::new(rng.range(lo, hi), rng.range(lo, hi), rng.range(lo, hi))
    };
    (0..count)
        .map(|_| {
            let c = v3(&mut rng, -10.0, 10.0);
            let shape = if ellipsoids {
                let radii = v3(&mut rng, 0.5, 2.0);
                let angles = v3(&mut rng, 0.0, 360.0);
                Shape::Ellipsoid(Ellipsoid::new(c, radii, rotation_xyz_degrees(angles)))
            } else {
                Shape::Sphere(Sphere::new(c, rng.range(0.2, 2.0)))
            };
            Primitive { shape, object: 0 }
        })
        .collect()
}
