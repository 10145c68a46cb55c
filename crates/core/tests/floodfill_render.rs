//! The flood-fill render mode (issue 7): S4's one bounce plus the voxel
//! cache, against the furnace answer, and its parsing and determinism.

use raylab::integrator::{FloodFillSettings, IntegratorKind};
use raylab::io::scene_file::{parse_scene, Overrides};
use raylab::stats::Counters;
use std::path::Path;

/// A closed cube [-1, 1]³ of inward-facing emissive triangles (L_e = 0.2,
/// albedo 0.8), seen from inside.
fn furnace() -> raylab::scene::Scene {
    let mut toml = String::from(
        "[image]\nwidth = 48\nheight = 48\n[camera]\neye = [0.0, 0.0, 0.5]\n\
         look_at = [0.3, -0.2, -1.0]\nfov = 70.0\n[render]\nsampler = \"random:4\"\n\
         accel = \"bvh\"\n[materials.w]\ncolor = [1.0, 1.0, 1.0]\ndiffuse = 0.8\n\
         ambient = 0.0\nemission = [0.2, 0.2, 0.2]\n",
    );
    // Each face as two triangles; winding does not matter (Lambertian and
    // emission are two-sided).
    for axis in 0..3 {
        for side in [-1.0f32, 1.0] {
            let corner = |a: f32, b: f32| {
                let mut p = [0.0f32; 3];
                p[axis] = side;
                p[(axis + 1) % 3] = a;
                p[(axis + 2) % 3] = b;
                format!("[{:.1}, {:.1}, {:.1}]", p[0], p[1], p[2])
            };
            for tri in [
                [corner(-1.0, -1.0), corner(1.0, -1.0), corner(1.0, 1.0)],
                [corner(-1.0, -1.0), corner(1.0, 1.0), corner(-1.0, 1.0)],
            ] {
                toml.push_str(&format!(
                    "[[triangle]]\nvertices = [{}, {}, {}]\nmaterial = \"w\"\n",
                    tri[0], tri[1], tri[2]
                ));
            }
        }
    }
    parse_scene(&toml, Path::new("furnace.toml"), &Overrides::default()).unwrap()
}

/// In a closed furnace the radiance everywhere is L_e/(1 − a) = 1. The
/// flood-fill render reaches it exactly in expectation: emission L_e at x₁,
/// direct light a·L_e there (NEE + MIS), and at x₂ emission plus a × the
/// cache, whose walls-reflecting fixed point is L_e/(1 − a) (crates/cli/tests/
/// floodfill.rs): L_e + a·L_e + a²·L_e/(1 − a) = L_e/(1 − a). Tolerance:
/// four standard errors of the image mean (from the film's own sample
/// variances, 9216 pixels × 4 samples) plus 1e-3 for the cache's
/// convergence (stopped at 10⁻⁴ of its largest value).
#[test]
fn floodfill_render_of_a_furnace_is_le_over_one_minus_albedo() {
    let s = furnace();
    let kind = IntegratorKind::parse("floodfill:res=12").unwrap();
    let (film, c) = kind.render::<Counters>(&s, Some(2)).unwrap();
    let n = film.pixels.len() as f64;
    let mean: f64 = film.pixels.iter().map(|p| f64::from(p.mean.x)).sum::<f64>() / n;
    let var: f64 = film
        .pixels
        .iter()
        .map(|p| f64::from(p.variance().x))
        .sum::<f64>()
        / n;
    let se = (var / (n * 4.0)).sqrt();
    assert!(
        (mean - 1.0).abs() < 4.0 * se + 1e-3,
        "mean {mean}, standard error {se}"
    );
    // One bounce only: at most one path ray per sample.
    assert!(c.path_rays <= c.camera_rays, "{c:?}");
}

/// The cache is read at the first bounce only, and the whole render — cache
/// build, propagation and frame — is the same on 1 and 2 threads.
#[test]
fn floodfill_render_is_deterministic() {
    let s = furnace();
    let kind = IntegratorKind::parse("floodfill:res=10,warm=50,lookup=trilinear").unwrap();
    let bits = |f: &raylab::film::Film| -> Vec<u32> {
        f.pixels
            .iter()
            .flat_map(|p| p.mean.to_array().map(f32::to_bits))
            .collect()
    };
    let (a, ca) = kind.render::<Counters>(&s, Some(1)).unwrap();
    let (b, cb) = kind.render::<Counters>(&s, Some(2)).unwrap();
    assert_eq!(ca, cb);
    assert_eq!(bits(&a), bits(&b));
}

#[test]
fn floodfill_specs_parse_round_trip_and_reject_nonsense() {
    for spec in [
        "floodfill",
        "floodfill:s4",
        "floodfill:res=32,lookup=trilinear,avg=gamma,warm=100,steps=3,max=2,bounce=off,alpha=1.5",
    ] {
        let kind = IntegratorKind::parse(spec).unwrap();
        let again = IntegratorKind::parse(&kind.name()).unwrap();
        assert_eq!(kind, again, "{spec} → {}", kind.name());
    }
    let s4 = FloodFillSettings::parse(":s4").unwrap();
    assert!((s4.config.alpha - 2.43902).abs() < 1e-6 && !s4.config.surface_bounce);
    for (bad, expect) in [
        ("floodfill:res=1", "`res`"),
        ("floodfill:lookup=nearest", "hemisphere, trilinear"),
        ("floodfill:alpha", "key=value"),
        ("floodfill:colour=red", "unknown floodfill option `colour`"),
        ("floodfillx", "floodfill[:key=value"),
        ("floodfill:steps=0", "`steps`"),
    ] {
        let err = IntegratorKind::parse(bad).unwrap_err();
        assert!(err.to_string().contains(expect), "{bad}: {err}");
    }
}
