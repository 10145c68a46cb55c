//! The one list of study kinds, [`KINDS`]: the manifest reader looks a
//! `kind` up here ([`find`]), `raylab experiment --help` lists it
//! ([`kinds_help`]), and the tests below hold the docs to it (every kind's
//! parameters documented, its example manifests of its kind, the book's
//! reference page describing it).

use super::{
    aa_images, aa_patterns, accel_cost, accel_speed, floodfill, gi_quality, gradient,
    gradient_estimators, render_cost,
};
use super::{DynStudy, ParamDoc};

/// One study kind.
pub struct StudyKind {
    /// The name a manifest's `kind` gives.
    pub name: &'static str,
    /// What it measures, in a line or two.
    pub summary: &'static str,
    /// Manifests in `analysis/` that run it (relative to the repository).
    pub examples: &'static [&'static str],
    /// The study itself.
    pub study: &'static dyn DynStudy,
}

impl std::fmt::Debug for StudyKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StudyKind")
            .field("name", &self.name)
            .finish()
    }
}

impl StudyKind {
    /// Its parameters, documented.
    pub fn parameters(&self) -> Vec<ParamDoc> {
        self.study.parameters()
    }
}

/// Every study kind a manifest may name, in the order `--help` lists them.
pub static KINDS: &[StudyKind] = &[
    StudyKind {
        name: "render_cost",
        summary: "time and counted work (rays, tests) of rendering a scene file",
        examples: &["analysis/s1-ogss-cost.toml"],
        study: &render_cost::RenderCost,
    },
    StudyKind {
        name: "aa_images",
        summary: "image-space aliasing: MSE, FLIP and error spectra of every sampler and \
                  filter against a converged reference, and the adaptive sampler's cost",
        examples: &["analysis/aa-images.toml"],
        study: &aa_images::AaImages,
    },
    StudyKind {
        name: "accel_cost",
        summary: "an accelerator on a mesh in an automatic S3-style scene: build and render \
                  time, tests per ray, bounding-volume test cost, wasted volume, image \
                  equality with brute force",
        examples: &["analysis/s3-bvh-ladder.toml", "analysis/bvh-volumes.toml"],
        study: &accel_cost::AccelCost,
    },
    StudyKind {
        name: "accel_speed",
        summary: "raylab's BVH against a reference accelerator (Embree) and optionally a \
                  peer (obvhs) on identical rays: Mrays/s and their ratios, work per ray, \
                  build times",
        examples: &["analysis/embree-speed.toml"],
        study: &accel_speed::AccelSpeed,
    },
    #[cfg(feature = "embree")]
    StudyKind {
        name: "embree_oracle",
        summary: "raylab's intersections validated against Embree over meshes and quadrics: \
                  disagreements by class, |dt|/t and normal-angle percentiles",
        examples: &["analysis/embree-oracle.toml"],
        study: &super::embree_oracle::EmbreeOracle,
    },
    #[cfg(feature = "gpu")]
    StudyKind {
        name: "gpu_speed",
        summary: "S3's GPU tables: brute force and a BVH on the CPU against the GPU port \
                  over a mesh ladder: build, upload, shader build, kernel and total times, \
                  rays/s, and the adapter (software or hardware)",
        examples: &["analysis/s3-gpu.toml"],
        study: &super::gpu_speed::GpuSpeed,
    },
    StudyKind {
        name: "aa_patterns",
        summary: "periodograms of the pixel samplers (as `raylab spectrum`), with overlaid \
                  radial and anisotropy curves",
        examples: &["analysis/aa-patterns.toml"],
        study: &aa_patterns::AaPatterns,
    },
    StudyKind {
        name: "gi_quality",
        summary: "time per frame, MSE, relMSE, FLIP, bias and variance of a \
                  global-illumination integrator against a converged reference",
        examples: &["analysis/s4-cornell.toml"],
        study: &gi_quality::GiQuality,
    },
    StudyKind {
        name: "gradient",
        summary: "derivatives of images by forward-mode AD: the image mean's derivative and \
                  its standard error, cost against the plain render for K parameters, and the \
                  error against central finite differences",
        examples: &["analysis/gradients.toml"],
        study: &gradient::Gradient,
    },
    StudyKind {
        name: "gradient_estimators",
        summary: "estimators of an image's derivative side by side (interior, interior + \
                  boundary term, finite differences): bias against a converged reference, \
                  standard error against spp, cost per sample, efficiency at equal time, \
                  and per-pixel standard-deviation maps",
        examples: &["analysis/gradient-estimators.toml"],
        study: &gradient_estimators::GradientEstimators,
    },
    StudyKind {
        name: "floodfill",
        summary: "S4's voxel flood-fill irradiance cache: residual per step, grid \
                  snapshots, step time, light leaking",
        examples: &["analysis/floodfill-convergence.toml"],
        study: &floodfill::FloodFillStudy,
    },
];

/// The study kind called `name`.
pub fn find(name: &str) -> Option<&'static StudyKind> {
    KINDS.iter().find(|k| k.name == name)
}

/// `text` in lines of at most `width` characters, each after `indent`.
fn wrap(text: &str, indent: &str, width: usize) -> String {
    let mut out = String::new();
    let mut line = String::new();
    for word in text.split_whitespace() {
        if !line.is_empty() && indent.len() + line.len() + 1 + word.chars().count() > width {
            out.push_str(indent);
            out.push_str(&line);
            out.push('\n');
            line.clear();
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(word);
    }
    if !line.is_empty() {
        out.push_str(indent);
        out.push_str(&line);
        out.push('\n');
    }
    out
}

/// The list of study kinds for `raylab experiment --help`: each kind's
/// name, what it measures, its parameters and its example manifests.
pub fn kinds_help() -> String {
    let mut s = String::from("Study kinds (the manifest's `kind`):\n");
    for k in KINDS {
        s.push_str(&format!("\n  {}\n", k.name));
        s.push_str(&wrap(k.summary, "      ", 80));
        let names: Vec<&str> = k.parameters().iter().map(|p| p.name).collect();
        s.push_str(&wrap(
            &format!("parameters: {}", names.join(", ")),
            "      ",
            80,
        ));
        s.push_str(&wrap(
            &format!("e.g. {}", k.examples.join(", ")),
            "      ",
            80,
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiment::load_manifest;
    use crate::experiment::study::StudySettings;

    #[test]
    fn names_are_unique_and_found() {
        for (i, k) in KINDS.iter().enumerate() {
            assert!(KINDS[..i].iter().all(|o| o.name != k.name), "{}", k.name);
            assert!(std::ptr::eq(find(k.name).unwrap(), k));
        }
        assert!(find("render_costs").is_none());
    }

    #[test]
    fn every_parameter_is_documented_in_field_order() {
        for k in KINDS {
            let documented: Vec<&str> = k.parameters().iter().map(|p| p.name).collect();
            assert_eq!(documented, k.study.parameter_names(), "kind {}", k.name);
            assert!(k.parameters().iter().all(|p| !p.doc.is_empty()));
        }
    }

    #[test]
    fn every_row_type_gives_columns() {
        for k in KINDS {
            for repeats in [1, 3] {
                let cols = k.study.columns(&StudySettings { repeats, warmup: 0 });
                assert!(!cols.is_empty(), "kind {}", k.name);
            }
        }
        let cols = find("render_cost").unwrap().study.columns(&StudySettings {
            repeats: 2,
            warmup: 0,
        });
        assert!(cols.contains(&"render_s_2".to_string()));
        assert!(!cols.contains(&"render_s_3".to_string()));
    }

    #[test]
    fn examples_are_manifests_of_their_kind_and_the_docs_describe_each_kind() {
        let repo = raylab_testkit::repo();
        let reference = repo.join("book/src/reference/studies.md");
        let docs = std::fs::read_to_string(&reference).unwrap();
        for k in KINDS {
            assert!(
                docs.contains(&format!("`{}`", k.name)),
                "{} does not describe the study kind `{}`",
                reference.display(),
                k.name
            );
            for e in k.examples {
                let m = load_manifest(&repo.join(e)).unwrap();
                assert_eq!(m.kind, k.name, "{e}");
                // Every run of the full and the quick version is valid.
                m.plan().unwrap();
                m.with_quick().unwrap().plan().unwrap();
            }
        }
        let help = kinds_help();
        assert!(KINDS.iter().all(|k| help.contains(k.name)));
        assert!(help.lines().all(|l| l.chars().count() <= 80), "{help}");
    }
}
