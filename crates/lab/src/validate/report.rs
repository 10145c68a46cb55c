//! Tallies of verdicts per ray set and accelerator, and what is made of
//! them: the printed table, the worst cases (printed and as CSV), the
//! histograms of |Δt|/t and of normal angles, a bar chart of the
//! disagreements, and the list of tolerance breaches that decides the exit
//! status.

use super::compare::{Answers, DisagreementKind, HitPlace, Leak, Outcome, Verdict};
use super::Tolerances;
use crate::analysis::plot::{AxisScale, BarChart, BarSeries, Histogram};
use crate::{Error, FileOp};
use raylab::io::{write_atomically, Place};
use raylab::math::Ray;
use std::fmt::Write as _;
use std::path::Path;

/// Counts and samples over one set of rays.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Tally {
    pub rays: u64,
    pub both_miss: u64,
    /// Same primitive on both sides.
    pub agree: u64,
    /// Different primitives at equal t at a shared edge or vertex.
    pub tie_edge: u64,
    /// Different primitives at equal t away from edges: coincident faces.
    pub tie_coincident: u64,
    /// Hit/miss disagreements by [`HitPlace`] (in [`HitPlace::ALL`] order).
    pub hit_miss: [u64; HitPlace::ALL.len()],
    /// Different primitives at different t, by [`HitPlace`] of the first.
    pub prim: [u64; HitPlace::ALL.len()],
    /// Edge and vertex disagreements where raylab missed (Embree was
    /// watertight) and where Embree missed.
    pub edge_leaks: (u64, u64),
    /// Any-hit disagreements explained by a borderline closest hit, and not.
    pub any_hit_explained: u64,
    pub any_hit_unexplained: u64,
    /// Same-primitive hits outside the t, (u, v) and normal tolerances.
    pub t_breaches: u64,
    pub uv_breaches: u64,
    pub normal_breaches: u64,
    /// |Δt|/t of same-primitive hits beyond the grazing angle.
    pub rel_dt: Vec<f32>,
    /// The largest of those above the coordinates' rounding floor (see
    /// [`Verdict::above_floor`]): the one the t tolerance bounds.
    pub max_rel_dt_above_floor: f32,
    /// Normal angles (rad) of same-primitive hits beyond the grazing angle.
    pub normal_angle: Vec<f32>,
}

impl Tally {
    /// Add one ray's verdict.
    pub fn add(&mut self, v: &Verdict, tol: &Tolerances) {
        self.rays += 1;
        match v.outcome {
            Outcome::BothMiss => self.both_miss += 1,
            Outcome::Agree => self.agree += 1,
            Outcome::Tie { coincident: true } => self.tie_coincident += 1,
            Outcome::Tie { coincident: false } => self.tie_edge += 1,
            Outcome::Disagree { kind, place, leak } => {
                let k = place.index();
                match kind {
                    DisagreementKind::HitMiss => self.hit_miss[k] += 1,
                    DisagreementKind::Prim => self.prim[k] += 1,
                }
                if matches!(place, HitPlace::Edge | HitPlace::Vertex) {
                    match leak {
                        Leak::Raylab => self.edge_leaks.0 += 1,
                        Leak::Embree => self.edge_leaks.1 += 1,
                    }
                }
            }
        }
        self.any_hit_explained += v.any_hit_explained as u64;
        self.any_hit_unexplained += v.any_hit_unexplained as u64;
        self.t_breaches += v.t_ratio.is_some_and(|r| r > 1.0) as u64;
        self.uv_breaches += v.uv_ratio.is_some_and(|r| r > 1.0) as u64;
        self.normal_breaches += v.normal_angle.is_some_and(|a| a > v.normal_tolerance) as u64;
        if v.cos >= tol.grazing_cos() {
            if let Some(r) = v.rel_dt {
                self.rel_dt.push(r);
                if v.above_floor {
                    self.max_rel_dt_above_floor = self.max_rel_dt_above_floor.max(r);
                }
            }
        }
        if let Some(a) = v.normal_angle {
            self.normal_angle.push(a);
        }
    }

    /// Merge another tally into this one.
    pub fn merge(&mut self, o: &Tally) {
        self.rays += o.rays;
        self.both_miss += o.both_miss;
        self.agree += o.agree;
        self.tie_edge += o.tie_edge;
        self.tie_coincident += o.tie_coincident;
        for k in 0..HitPlace::ALL.len() {
            self.hit_miss[k] += o.hit_miss[k];
            self.prim[k] += o.prim[k];
        }
        self.edge_leaks.0 += o.edge_leaks.0;
        self.edge_leaks.1 += o.edge_leaks.1;
        self.any_hit_explained += o.any_hit_explained;
        self.any_hit_unexplained += o.any_hit_unexplained;
        self.t_breaches += o.t_breaches;
        self.uv_breaches += o.uv_breaches;
        self.normal_breaches += o.normal_breaches;
        self.rel_dt.extend_from_slice(&o.rel_dt);
        self.max_rel_dt_above_floor = self.max_rel_dt_above_floor.max(o.max_rel_dt_above_floor);
        self.normal_angle.extend_from_slice(&o.normal_angle);
    }

    /// Disagreements (hit/miss and primitive) at a [`HitPlace`].
    pub fn disagreements_at(&self, place: HitPlace) -> u64 {
        let k = place.index();
        self.hit_miss[k] + self.prim[k]
    }

    /// Disagreements rounding explains: at edges, vertices, or grazing.
    pub fn borderline(&self) -> u64 {
        self.disagreements_at(HitPlace::Edge)
            + self.disagreements_at(HitPlace::Vertex)
            + self.disagreements_at(HitPlace::Grazing)
    }

    /// Everything the tolerances count against: disagreements elsewhere,
    /// unexplained any-hit differences, t, (u, v) and normal breaches.
    pub fn unexplained(&self) -> u64 {
        self.disagreements_at(HitPlace::Elsewhere)
            + self.any_hit_unexplained
            + self.t_breaches
            + self.uv_breaches
            + self.normal_breaches
    }

    /// Rays that hit something on both sides or on either.
    pub fn hits(&self) -> u64 {
        self.rays - self.both_miss
    }

    /// p50, p99 and max of |Δt|/t (NaN without samples).
    pub fn rel_dt_percentiles(&self) -> [f64; 3] {
        percentiles(&self.rel_dt)
    }

    /// p50, p99 and max of the normal angle in radians.
    pub fn normal_angle_percentiles(&self) -> [f64; 3] {
        percentiles(&self.normal_angle)
    }
}

/// p50, p99 and max of a sample (nearest rank; NaN when empty).
pub fn percentiles(values: &[f32]) -> [f64; 3] {
    if values.is_empty() {
        return [f64::NAN; 3];
    }
    let mut s = values.to_vec();
    s.sort_by(f32::total_cmp);
    let rank = |q: f64| s[((q * s.len() as f64).ceil() as usize).clamp(1, s.len()) - 1] as f64;
    [rank(0.5), rank(0.99), s[s.len() - 1] as f64]
}

/// The tally of one ray set traced with one accelerator.
#[derive(Clone, Debug, PartialEq)]
pub struct SetReport {
    pub set: &'static str,
    pub accel: String,
    pub tally: Tally,
}

/// One ray with both answers, kept as a worst case.
#[derive(Clone, Debug, PartialEq)]
pub struct Case {
    pub set: &'static str,
    pub accel: String,
    /// Index of the ray in its set.
    pub index: usize,
    pub ray: Ray,
    pub answers: Answers,
    pub verdict: Verdict,
}

impl Case {
    /// How bad the case is, for ordering: a breach of the tolerances comes
    /// first, then any disagreement, then the largest |Δt| over tolerance.
    pub fn severity(&self) -> (u8, u8, f32) {
        let disagree = matches!(self.verdict.outcome, Outcome::Disagree { .. });
        (
            self.verdict.breaks() as u8,
            disagree as u8,
            self.verdict.t_ratio.unwrap_or(0.0),
        )
    }

    /// The verdict in a word or two.
    pub fn class(&self) -> String {
        match self.verdict.outcome {
            Outcome::BothMiss => "both miss".into(),
            Outcome::Agree => "same primitive".into(),
            Outcome::Tie { coincident: true } => "tie: coincident faces".into(),
            Outcome::Tie { coincident: false } => "tie: shared edge".into(),
            Outcome::Disagree { kind, place, leak } => format!(
                "{} at {}, {} leaked",
                match kind {
                    DisagreementKind::HitMiss => "hit/miss",
                    DisagreementKind::Prim => "primitive",
                },
                place.name(),
                match leak {
                    Leak::Raylab => "raylab",
                    Leak::Embree => "Embree",
                }
            ),
        }
    }
}

/// The whole run: a tally per (set, accelerator), the worst cases.
#[derive(Clone, Debug, PartialEq)]
pub struct ValidationReport {
    /// What was validated (file name).
    pub input: String,
    /// Primitives compared (bounded ones; planes are left out).
    pub primitives: usize,
    pub triangles: usize,
    /// Whether the triangles form a closed mesh (every edge shared by two).
    pub closed: bool,
    /// The Embree configuration and library version.
    pub embree: String,
    pub sets: Vec<SetReport>,
    pub worst: Vec<Case>,
}

fn fmt_e(x: f64) -> String {
    if x.is_nan() {
        "-".into()
    } else {
        format!("{x:.1e}")
    }
}

impl ValidationReport {
    /// Every set and accelerator merged.
    pub fn overall(&self) -> Tally {
        let mut t = Tally::default();
        for s in &self.sets {
            t.merge(&s.tally);
        }
        t
    }

    /// The tolerances this run breaks, one line each (empty: it passes).
    pub fn breaches(&self, tol: &Tolerances) -> Vec<String> {
        let mut out = Vec::new();
        for s in &self.sets {
            let t = &s.tally;
            let name = format!("{} ({})", s.set, s.accel);
            if t.unexplained() > tol.max_unexplained {
                out.push(format!(
                    "{name}: {} unexplained (allowed {}): {} disagreements away from edges, \
                     vertices and grazing hits, {} any-hit, {} |Δt| > tolerance, \
                     {} (u,v), {} normal > {:.1e} rad",
                    t.unexplained(),
                    tol.max_unexplained,
                    t.disagreements_at(HitPlace::Elsewhere),
                    t.any_hit_unexplained,
                    t.t_breaches,
                    t.uv_breaches,
                    t.normal_breaches,
                    tol.normal_angle
                ));
            }
            if let Some(max) = tol.max_borderline {
                if t.borderline() > max {
                    out.push(format!(
                        "{name}: {} edge/vertex/grazing disagreements (allowed {max})",
                        t.borderline()
                    ));
                }
            }
        }
        out
    }

    /// The table printed by `raylab validate`.
    pub fn table(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "input      {}: {} primitives ({} triangles, {}), Embree {}",
            self.input,
            self.primitives,
            self.triangles,
            if self.closed { "closed" } else { "not closed" },
            self.embree
        );
        let _ = writeln!(
            s,
            "{:<15} {:<14} {:>8} {:>8} {:>6} {:>6} | {:>6} {:>6} {:>6} {:>6} {:>6} | {:>5} {:>5} | {:>5} {:>5} | {:>8} {:>8} {:>8} {:>8}",
            "set", "accel", "rays", "hits", "tieE", "tieC", "edge", "vert", "graz", "orig", "else",
            "lkR", "lkE", "anyX", "bad", "dt p50", "dt p99", "dt max", "n max"
        );
        let mut row = |set: &str, accel: &str, t: &Tally| {
            let dt = t.rel_dt_percentiles();
            let n = t.normal_angle_percentiles();
            let _ = writeln!(
                s,
                "{:<15} {:<14} {:>8} {:>8} {:>6} {:>6} | {:>6} {:>6} {:>6} {:>6} {:>6} | {:>5} {:>5} | {:>5} {:>5} | {:>8} {:>8} {:>8} {:>8}",
                set,
                accel,
                t.rays,
                t.hits(),
                t.tie_edge,
                t.tie_coincident,
                t.disagreements_at(HitPlace::Edge),
                t.disagreements_at(HitPlace::Vertex),
                t.disagreements_at(HitPlace::Grazing),
                t.disagreements_at(HitPlace::Origin),
                t.disagreements_at(HitPlace::Elsewhere),
                t.edge_leaks.0,
                t.edge_leaks.1,
                t.any_hit_explained,
                t.unexplained(),
                fmt_e(dt[0]),
                fmt_e(dt[1]),
                fmt_e(dt[2]),
                fmt_e(n[2]),
            );
        };
        for r in &self.sets {
            row(r.set, &r.accel, &r.tally);
        }
        row("overall", "", &self.overall());
        s.push_str(
            "tieE/tieC: other primitive at equal t, at a shared edge / coincident faces; \
             edge..else: disagreements (hit/miss or primitive) by place of the first hit \
             (orig: at the ray's origin, a ray that starts on a surface; not counted as bad); \
             lkR/lkE: edge/vertex disagreements where raylab / Embree missed (leaked); \
             anyX: any-hit differences explained by those; bad: unexplained + tolerance breaches; \
             dt: |Δt|/t beyond the grazing angle; n: normal angle (rad)\n",
        );
        s
    }

    /// The worst cases, one line each.
    pub fn worst_text(&self) -> String {
        let opt = |x: Option<f32>| x.map_or("-".into(), |v| format!("{v:.2e}"));
        let mut s = String::new();
        for c in &self.worst {
            let _ = writeln!(
                s,
                "{} ({}) ray {}: {} (|cos θ| {:.2e}, |Δt|/tol {}, Δ(u,v)/tol {}, normal {}); \
                 origin {:?} dir {:?}; raylab {}; Embree {}",
                c.set,
                c.accel,
                c.index,
                c.class(),
                c.verdict.cos,
                opt(c.verdict.t_ratio),
                opt(c.verdict.uv_ratio),
                opt(c.verdict.normal_angle),
                c.ray.origin.to_array(),
                c.ray.dir.to_array(),
                c.answers.ours.map_or("miss".into(), |a| format!(
                    "prim {} t {:e}",
                    a.prim, a.hit.t
                )),
                c.answers.theirs.map_or("miss".into(), |e| format!(
                    "prim {} t {:e}",
                    e.prim, e.hit.t
                )),
            );
        }
        s
    }

    /// Write the worst cases as CSV (atomically).
    pub fn write_csv(&self, path: &Path) -> Result<(), Error> {
        let csv_error = |op, e| Error::csv(path, Place::File, op, e);
        write_atomically(path, |tmp| {
            let mut w = csv::Writer::from_path(tmp).map_err(|e| csv_error(FileOp::Create, e))?;
            w.write_record([
                "set",
                "accel",
                "ray",
                "class",
                "ox",
                "oy",
                "oz",
                "dx",
                "dy",
                "dz",
                "raylab_prim",
                "raylab_t",
                "embree_prim",
                "embree_t",
                "rel_dt",
                "dt_over_tolerance",
                "normal_angle",
                "cos_incidence",
            ])
            .map_err(|e| csv_error(FileOp::Write, e))?;
            let opt = |x: Option<f32>| x.map_or(String::new(), |v| format!("{v:e}"));
            for c in &self.worst {
                let (o, d) = (c.ray.origin, c.ray.dir);
                let ours = c.answers.ours;
                let theirs = c.answers.theirs;
                w.write_record([
                    c.set.to_string(),
                    c.accel.clone(),
                    c.index.to_string(),
                    c.class(),
                    format!("{:e}", o.x),
                    format!("{:e}", o.y),
                    format!("{:e}", o.z),
                    format!("{:e}", d.x),
                    format!("{:e}", d.y),
                    format!("{:e}", d.z),
                    ours.map_or(String::new(), |a| a.prim.to_string()),
                    opt(ours.map(|a| a.hit.t)),
                    theirs.map_or(String::new(), |e| e.prim.to_string()),
                    opt(theirs.map(|e| e.hit.t)),
                    opt(c.verdict.rel_dt),
                    opt(c.verdict.t_ratio),
                    opt(c.verdict.normal_angle),
                    format!("{:e}", c.verdict.cos),
                ])
                .map_err(|e| csv_error(FileOp::Write, e))?;
            }
            w.flush().map_err(|e| Error::io(path, FileOp::Write, e))?;
            Ok(())
        })
    }

    /// Write the figures into `dir`: histograms of log₁₀ |Δt|/t and of
    /// log₁₀ normal angle (exact agreement, 0, is counted in the title, as
    /// a log axis cannot show it), and a bar chart of disagreements by
    /// place per ray set (only when there is one). Returns the stems
    /// written.
    pub fn write_figures(&self, dir: &Path, stem_prefix: &str) -> Result<Vec<String>, Error> {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, FileOp::CreateFolder, e))?;
        let all = self.overall();
        let mut stems = Vec::new();
        for (name, values, what) in [
            ("rel-dt", &all.rel_dt, "|Δt|/t"),
            ("normal-angle", &all.normal_angle, "normal angle (rad)"),
        ] {
            let exact = values.iter().filter(|&&v| v == 0.0).count();
            let logs: Vec<f64> = values
                .iter()
                .filter(|&&v| v > 0.0)
                .map(|&v| (v as f64).log10())
                .collect();
            let mut h = Histogram::new(
                format!(
                    "{}: {what} ({} hits, {exact} equal)",
                    self.input,
                    values.len()
                ),
                format!("log₁₀ {what}, raylab vs Embree, beyond the grazing angle"),
                logs,
                40,
            );
            h.y_label = "same-primitive hits".into();
            h.y_scale = AxisScale::Log10;
            let stem = format!("{stem_prefix}{name}");
            h.save(&dir.join(&stem))?;
            stems.push(stem);
        }
        let mut sets: Vec<&'static str> = self.sets.iter().map(|s| s.set).collect();
        sets.dedup();
        let mut bars = BarChart::new(
            format!("{}: disagreements with Embree by place", self.input),
            "ray set",
            "rays (all accelerators)",
            sets.iter().map(|s| s.to_string()).collect(),
        );
        for place in HitPlace::ALL {
            let values = sets
                .iter()
                .map(|&set| {
                    self.sets
                        .iter()
                        .filter(|r| r.set == set)
                        .map(|r| r.tally.disagreements_at(place) as f64)
                        .sum()
                })
                .collect();
            bars.series.push(BarSeries::new(place.name(), values));
        }
        // A log axis shows counts from 1 to 10⁴ alike; with no
        // disagreement at all there is nothing to draw.
        if bars.series.iter().flat_map(|s| &s.values).any(|&v| v > 0.0) {
            bars.y_scale = AxisScale::Log10;
            let stem = format!("{stem_prefix}disagreements");
            bars.save(&dir.join(&stem))?;
            stems.push(stem);
        }
        Ok(stems)
    }
}
