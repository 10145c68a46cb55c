//! `kind = "accel_speed"`: traversal throughput of one of raylab's
//! accelerators against a reference accelerator (Embree 4 by default) and,
//! optionally, a peer (`peer`, e.g. the obvhs crate's 8-wide compressed
//! BVH) on identical rays, measured in the same run
//! (`analysis/embree-speed.toml`).
//!
//! One run loads a scene, builds the accelerators (each build timed:
//! `warmup` untimed builds, then `repeats` timed ones but at least
//! [`BUILD_REPEATS`], each library's back to back, medians reported),
//! makes the four ray sets of [`raylab::workload`] (primary, shadow,
//! diffuse, random) once, and then, for each set, times the accelerators
//! alternately (`warmup` untimed passes each, then `repeats` timed passes
//! of A, B, A, B, … or, with a peer, A, B, C, A, B, C, …) so that a
//! disturbance of the machine falls on every side rather than one. The
//! timed loop is [`trace`]: `intersect` (closest hit) or `occluded`
//! (shadow rays: any hit) on each ray, through the accelerators' public
//! interface — Embree's through `rtcIntersect1`/`rtcOccluded1`, obvhs's
//! through `CwBvh::ray_traverse`/`ray_traverse_miss`, one ray at a time —
//! on a rayon pool of `threads` workers built before any clock starts.
//!
//! Columns `{kind}_nodes_per_ray`, `…_volume_tests_per_ray` and
//! `…_prim_tests_per_ray` count the work behind our side's time (one extra
//! pass with [`Counters`]; Embree and obvhs do not count).
//!
//! The sides must agree on which rays hit (`{kind}_hit_disagree` against
//! the reference, `{kind}_peer_hit_disagree` against the peer: the number
//! of rays where only one of the two found a hit; rounding at edges allows
//! a handful in a million, see `raylab validate`, and obvhs's triangle
//! test, not watertight, a few more): a throughput figure for a different
//! answer would compare nothing.
//!
//! The peer's columns (`peer_build_median_s`, then per ray kind
//! `peer_{kind}_median_s`, `peer_{kind}_mrays_s`, `{kind}_peer_ratio` =
//! ours / peer, `{kind}_peer_hit_disagree`) come after all the others, so
//! a table without a peer has the columns it always had, followed by these
//! left empty.

use super::{RunContext, Study, Timings};
use crate::experiment::params::render::scene_file;
use crate::experiment::params::{
    or_default, parsed_opt, typed_params, InRange, ParamDoc, Resolution, RunParamError,
};
use crate::experiment::row::{Fixed, Secs};
use crate::experiment::sweep::RunPoint;
use crate::Error;
use raylab::accel::{Accel, AccelKind, Accelerator};
use raylab::io::scene_file::{load_scene, Overrides};
use raylab::scene::Scene;
use raylab::shape::PreparedRay;
use raylab::stats::{Counters, NoStats};
use raylab::workload::{trace, trace_serial, Segment, Workload};
use rayon::prelude::*;
use serde::ser::SerializeMap;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Fewest timed builds per accelerator: a build of these meshes takes a
/// few milliseconds, where a handful of samples would leave the median at
/// the mercy of one disturbance.
pub const BUILD_REPEATS: u32 = 15;

/// The `accel_speed` study.
#[derive(Clone, Copy, Debug, Default)]
pub struct AccelSpeed;

/// The parameters of a run.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AccelSpeedParams {
    /// Scene file, relative to the manifest's folder.
    pub scene: String,
    /// raylab's accelerator to measure.
    #[serde(default, deserialize_with = "parsed_opt")]
    pub accel: Option<AccelKind>,
    /// The accelerator it is measured against.
    #[serde(default, deserialize_with = "parsed_opt")]
    pub reference: Option<AccelKind>,
    /// A third accelerator timed beside the two.
    #[serde(default, deserialize_with = "parsed_opt")]
    pub peer: Option<AccelKind>,
    /// Camera rays "WxH".
    #[serde(default, deserialize_with = "parsed_opt")]
    pub resolution: Option<Resolution>,
    /// Rays through the scene's bounds.
    #[serde(default)]
    pub random_rays: Option<InRange<0, { 1 << 30 }>>,
    /// Worker threads tracing.
    #[serde(default)]
    pub threads: Option<InRange<1, 1024>>,
    /// Seed of the diffuse and random rays.
    #[serde(default)]
    pub seed: Option<u64>,
}

typed_params!(
    AccelSpeedParams,
    [
        ParamDoc {
            name: "scene",
            doc: "scene file (TOML), relative to the manifest's folder; required",
        },
        ParamDoc {
            name: "accel",
            doc: "raylab's accelerator to measure (default `bvh4`, the 4-wide SAH box BVH)",
        },
        ParamDoc {
            name: "reference",
            doc: "the accelerator it is measured against (default `embree:high+robust`)",
        },
        ParamDoc {
            name: "peer",
            doc: "a third accelerator timed beside the two on the same rays, e.g. `obvhs` \
                  (default none: its `peer_…` columns are left empty)",
        },
        ParamDoc {
            name: "resolution",
            doc: "camera rays \"WxH\" (default \"800x600\"); shadow and diffuse rays start \
                  at their hits",
        },
        ParamDoc {
            name: "random_rays",
            doc: "rays through the bounds (default: as many as pixels)",
        },
        ParamDoc {
            name: "threads",
            doc: "worker threads tracing (default 1)",
        },
        ParamDoc {
            name: "seed",
            doc: "seed of the diffuse and random rays (default 1)",
        },
    ]
);

/// A run's parameters, checked.
pub struct AccelSpeedConfig {
    scene: PathBuf,
    accel: AccelKind,
    reference: AccelKind,
    peer: Option<AccelKind>,
    width: u32,
    height: u32,
    random: Option<usize>,
    threads: usize,
    seed: u64,
}

/// Whether each ray of `rays` hits, through `accel` (any-hit or closest).
fn hit_flags(accel: &Accelerator, scene: &Scene, rays: &[Segment], any_hit: bool) -> Vec<bool> {
    let prims = &scene.prims[..];
    rays.par_iter()
        .map(|r: &Segment| {
            let ray: &PreparedRay = &r.ray;
            if any_hit {
                accel.occluded(prims, ray, r.t_max, &mut NoStats)
            } else {
                accel.intersect(prims, ray, r.t_max, &mut NoStats).is_some()
            }
        })
        .collect()
}

/// The two sides of a row: raylab's accelerator and the reference.
pub const SIDES: [&str; 2] = ["ours", "ref"];

/// One ray set's columns.
#[derive(Clone, Copy, Debug, Default)]
pub struct KindCells {
    /// Rays in the set.
    pub rays: usize,
    /// Rays our side found a hit for.
    pub hits: usize,
    /// Rays where only one side found a hit.
    pub hit_disagree: usize,
    /// Median time of each side ([`SIDES`]).
    pub median_s: [Secs; 2],
    /// Throughput of each side, Mrays/s.
    pub mrays_s: [Fixed<4>; 2],
    /// Our throughput over the reference's.
    pub ratio: Fixed<4>,
    /// Nodes visited per ray (our side).
    pub nodes_per_ray: Fixed<3>,
    /// Bounding-volume tests per ray (our side).
    pub volume_tests_per_ray: Fixed<3>,
    /// Primitive tests per ray (our side).
    pub prim_tests_per_ray: Fixed<3>,
}

/// The columns of every ray set, in [`Workload::KINDS`] order, each named
/// after its kind: `primary_rays`, …, `ours_primary_median_s`, ….
#[derive(Clone, Copy, Debug, Default)]
pub struct PerKind(pub [KindCells; 4]);

impl Serialize for PerKind {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut map = s.serialize_map(None)?;
        for (k, c) in Workload::KINDS.iter().zip(&self.0) {
            map.serialize_entry(&format!("{k}_rays"), &c.rays)?;
            map.serialize_entry(&format!("{k}_hits"), &c.hits)?;
            map.serialize_entry(&format!("{k}_hit_disagree"), &c.hit_disagree)?;
            for (i, side) in SIDES.iter().enumerate() {
                map.serialize_entry(&format!("{side}_{k}_median_s"), &c.median_s[i])?;
                map.serialize_entry(&format!("{side}_{k}_mrays_s"), &c.mrays_s[i])?;
            }
            map.serialize_entry(&format!("{k}_ratio"), &c.ratio)?;
            map.serialize_entry(&format!("{k}_nodes_per_ray"), &c.nodes_per_ray)?;
            map.serialize_entry(
                &format!("{k}_volume_tests_per_ray"),
                &c.volume_tests_per_ray,
            )?;
            map.serialize_entry(&format!("{k}_prim_tests_per_ray"), &c.prim_tests_per_ray)?;
        }
        map.end()
    }
}

/// The peer's columns of one ray set.
#[derive(Clone, Copy, Debug, Default)]
pub struct PeerCells {
    /// Median time of the peer.
    pub median_s: Secs,
    /// Throughput of the peer, Mrays/s.
    pub mrays_s: Fixed<4>,
    /// Our throughput over the peer's.
    pub ratio: Fixed<4>,
    /// Rays where only one of ours and the peer found a hit.
    pub hit_disagree: usize,
}

/// The peer's columns of every ray set, in [`Workload::KINDS`] order:
/// `peer_camera_median_s`, `peer_camera_mrays_s`, `camera_peer_ratio`,
/// `camera_peer_hit_disagree`, `peer_shadow_median_s`, …; every cell empty
/// without a peer.
#[derive(Clone, Copy, Debug, Default)]
pub struct PeerPerKind(pub Option<[PeerCells; 4]>);

impl Serialize for PeerPerKind {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut map = s.serialize_map(None)?;
        for (i, k) in Workload::KINDS.iter().enumerate() {
            let c = self.0.map(|cells| cells[i]);
            map.serialize_entry(&format!("peer_{k}_median_s"), &c.map(|c| c.median_s))?;
            map.serialize_entry(&format!("peer_{k}_mrays_s"), &c.map(|c| c.mrays_s))?;
            map.serialize_entry(&format!("{k}_peer_ratio"), &c.map(|c| c.ratio))?;
            map.serialize_entry(
                &format!("{k}_peer_hit_disagree"),
                &c.map(|c| c.hit_disagree),
            )?;
        }
        map.end()
    }
}

/// Rays where exactly one of two sides found a hit.
fn disagreements(a: &[bool], b: &[bool]) -> usize {
    a.iter().zip(b).filter(|(a, b)| a != b).count()
}

/// One row: the accelerators on one scene's four ray sets.
#[derive(Clone, Debug, Default, Serialize)]
pub struct AccelSpeedRow {
    /// Triangles of the scene.
    pub triangles: usize,
    /// Bounded primitives (what the accelerators hold).
    pub primitives: usize,
    /// Worker threads tracing.
    pub threads: usize,
    /// Median build time of our accelerator.
    pub ours_build_median_s: Secs,
    /// Median build time of the reference.
    pub ref_build_median_s: Secs,
    /// The ray sets.
    #[serde(flatten)]
    pub kinds: PerKind,
    /// Median build time of the peer (empty without one).
    pub peer_build_median_s: Option<Secs>,
    /// The peer's columns of each ray set (empty without one).
    #[serde(flatten)]
    pub peer: PeerPerKind,
}

impl Study for AccelSpeed {
    type Params = AccelSpeedParams;
    type Config = AccelSpeedConfig;
    type Row = AccelSpeedRow;

    fn configure(
        &self,
        p: AccelSpeedParams,
        base_dir: &Path,
    ) -> Result<AccelSpeedConfig, RunParamError> {
        let res = p.resolution.unwrap_or(Resolution {
            width: 800,
            height: 600,
        });
        Ok(AccelSpeedConfig {
            scene: scene_file(base_dir, &p.scene)?,
            accel: or_default(p.accel, "accel", "bvh")?,
            reference: or_default(p.reference, "reference", "embree:high+robust")?,
            peer: p.peer,
            width: res.width,
            height: res.height,
            random: p.random_rays.map(|n| n.get() as usize),
            threads: p.threads.map_or(1, |t| t.get() as usize),
            seed: p.seed.unwrap_or(1),
        })
    }

    fn run(
        &self,
        cfg: AccelSpeedConfig,
        _run: &RunPoint,
        ctx: &RunContext<'_>,
    ) -> Result<AccelSpeedRow, Error> {
        let overrides = Overrides {
            width: Some(cfg.width),
            height: Some(cfg.height),
            accel: Some(cfg.accel),
            ..Default::default()
        };
        let scene = load_scene(&cfg.scene, &overrides)?;
        let bounded: Vec<u32> = (0..scene.prims.len() as u32)
            .filter(|&i| scene.prims[i as usize].bounds().is_some())
            .collect();
        let (warmup, repeats) = (ctx.settings.warmup, ctx.settings.repeats);
        // The sides in timing order: ours, the reference, the peer.
        let kinds_built: Vec<AccelKind> = [cfg.accel, cfg.reference]
            .into_iter()
            .chain(cfg.peer)
            .collect();
        let mut sides = Vec::new();
        let mut build_s = vec![Secs::default(); kinds_built.len()];
        for (i, &kind) in kinds_built.iter().enumerate() {
            // Each library's builds back to back, not in turn with the
            // others': Embree's worker threads keep spinning for a while
            // after a build, and would slow whatever build came next.
            let build = Timings::measure(warmup, repeats.max(BUILD_REPEATS), || {
                Accelerator::build(kind, &scene.prims, bounded.clone())
            });
            let accel = Accelerator::build(kind, &scene.prims, bounded.clone())
                .map_err(Error::accel(kind))?;
            build_s[i] = Secs(build.median());
            sides.push(accel);
        }
        let random = cfg.random.unwrap_or((cfg.width * cfg.height) as usize);
        let work = Workload::from_scene(&scene, random, cfg.seed);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(cfg.threads)
            .build()
            .map_err(Error::Threads)?;
        let mut kinds = PerKind::default();
        let mut peer = [PeerCells::default(); 4];
        for (j, (k, cells)) in Workload::KINDS.into_iter().zip(&mut kinds.0).enumerate() {
            let rays = work.get(k);
            let flags: Vec<Vec<bool>> = sides
                .iter()
                .map(|a| hit_flags(a, &scene, rays, k.any_hit()))
                .collect();
            let mut times: Vec<Vec<f64>> = vec![Vec::new(); sides.len()];
            pool.install(|| {
                for a in &sides {
                    for _ in 0..warmup {
                        std::hint::black_box(trace(a, &scene, rays, k.any_hit()));
                    }
                }
                for _ in 0..repeats {
                    for (i, a) in sides.iter().enumerate() {
                        let t = Timings::measure(0, 1, || trace(a, &scene, rays, k.any_hit()));
                        times[i].push(t.seconds[0]);
                    }
                }
            });
            cells.rays = rays.len();
            cells.hits = flags[0].iter().filter(|&&h| h).count();
            cells.hit_disagree = disagreements(&flags[0], &flags[1]);
            let medians: Vec<f64> = times.iter().map(|t| super::median(t)).collect();
            let mrays: Vec<f64> = medians
                .iter()
                .map(|m| rays.len() as f64 / m / 1e6)
                .collect();
            for i in 0..SIDES.len() {
                cells.median_s[i] = Secs(medians[i]);
                cells.mrays_s[i] = Fixed(mrays[i]);
            }
            cells.ratio = Fixed(mrays[0] / mrays[1]);
            if sides.len() > SIDES.len() {
                peer[j] = PeerCells {
                    median_s: Secs(medians[2]),
                    mrays_s: Fixed(mrays[2]),
                    ratio: Fixed(mrays[0] / mrays[2]),
                    hit_disagree: disagreements(&flags[0], &flags[2]),
                };
            }
            // The work behind our side's time, counted in one more pass.
            let mut c = Counters::default();
            trace_serial(&sides[0], &scene, rays, k.any_hit(), &mut c);
            let per_ray = |n: u64| Fixed(n as f64 / rays.len().max(1) as f64);
            cells.nodes_per_ray = per_ray(c.nodes_visited);
            cells.volume_tests_per_ray =
                per_ray(c.box_tests + c.bounding_sphere_tests + c.bounding_ellipsoid_tests);
            cells.prim_tests_per_ray =
                per_ray(c.triangle_tests + c.sphere_tests + c.ellipsoid_tests);
        }
        Ok(AccelSpeedRow {
            triangles: scene.triangle_count(),
            primitives: bounded.len(),
            threads: cfg.threads,
            ours_build_median_s: build_s[0],
            ref_build_median_s: build_s[1],
            kinds,
            peer_build_median_s: build_s.get(2).copied(),
            peer: PeerPerKind(cfg.peer.map(|_| peer)),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiment::row::record;

    /// Without a peer the row has the columns it had before peers (the
    /// peer's come after all of them) and the peer's cells are empty; with
    /// one they are filled.
    #[test]
    fn peer_columns_come_last_and_are_empty_without_a_peer() {
        let rec = record(&AccelSpeedRow::default()).unwrap();
        let first_peer = rec
            .columns
            .iter()
            .position(|c| c == "peer_build_median_s")
            .unwrap();
        assert_eq!(rec.columns.len() - first_peer, 1 + 4 * 4);
        assert_eq!(rec.columns[first_peer - 1], "random_prim_tests_per_ray");
        assert!(rec.cells[first_peer..].iter().all(String::is_empty));
        assert_eq!(rec.get("camera_ratio"), Some("0.0000"));

        let row = AccelSpeedRow {
            peer_build_median_s: Some(Secs(0.5)),
            peer: PeerPerKind(Some(
                [PeerCells {
                    median_s: Secs(0.25),
                    mrays_s: Fixed(2.0),
                    ratio: Fixed(1.5),
                    hit_disagree: 3,
                }; 4],
            )),
            ..Default::default()
        };
        let filled = record(&row).unwrap();
        assert_eq!(filled.columns, rec.columns);
        assert_eq!(filled.get("peer_build_median_s"), Some("0.500000000"));
        assert_eq!(filled.get("peer_path_mrays_s"), Some("2.0000"));
        assert_eq!(filled.get("random_peer_ratio"), Some("1.5000"));
        assert_eq!(filled.get("shadow_peer_hit_disagree"), Some("3"));
    }
}
