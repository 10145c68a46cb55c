//! Anti-aliasing (issue 6): the adaptive supersampler, reconstruction
//! filters and the aliasing test textures, against answers computed here.

use raylab::film::{Film, Filter};
use raylab::integrator::{render, render_with_costs, Whitted};
use raylab::io::scene_file::{load_scene, parse_scene, Overrides};
use raylab::sampler::Sampler;
use raylab::scene::Scene;
use raylab::stats::Counters;
use std::path::Path;

/// A card seen head-on, the view spanning [-1, 1]² at z = 0 on W×W pixels,
/// ambient light only (each sample's value is the surface colour there),
/// with the given material lines.
fn card(width: u32, material: &str, overrides: &Overrides) -> Scene {
    let toml = format!(
        r#"
[image]
width = {width}
height = {width}
[camera]
eye = [0.0, 0.0, 2.0]
look_at = [0.0, 0.0, 0.0]
fov = 53.130102
[render]
background = [0.0, 0.0, 0.0]
ambient = [1.0, 1.0, 1.0]
max_depth = 1
[materials.card]
ambient = 1.0
diffuse = 0.0
{material}
[[plane]]
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
material = "card"
"#
    );
    parse_scene(&toml, Path::new("card.toml"), overrides).unwrap()
}

fn with_sampler(spec: &str) -> Overrides {
    Overrides {
        sampler: Some(Sampler::parse(spec).unwrap()),
        ..Default::default()
    }
}

fn bits(f: &Film) -> Vec<u32> {
    f.image().iter().map(|v| v.to_bits()).collect()
}

/// A card of one colour has no contrast anywhere: the adaptive sampler
/// traces the (W+1)² corner lattice and nothing more, each pixel's count
/// is what it owns of the lattice, and the counts sum to the rays traced.
#[test]
fn adaptive_on_a_flat_card_traces_only_the_corner_lattice() {
    let w = 20;
    let s = card(
        w,
        "color = [0.3, 0.5, 0.7]",
        &with_sampler("adaptive:0.01:3"),
    );
    let (film, c) = render::<_, Counters>(&s, &Whitted, Some(2));
    assert_eq!(c.camera_rays, u64::from((w + 1) * (w + 1)));
    let counted: u64 = film.pixels.iter().map(|p| u64::from(p.count)).sum();
    assert_eq!(counted, c.camera_rays);
    assert_eq!(film.pixel(0, 0).count, 1);
    assert_eq!(film.pixel(w - 1, w - 1).count, 4);
    for p in &film.pixels {
        assert!(
            (p.mean - raylab::math::Vec3::new(0.3, 0.5, 0.7))
                .abs()
                .max_element()
                < 1e-6
        );
    }
}

/// A vertical black/white edge at x = 0.3 (a checker of huge squares with
/// its origin moved there; the card spans [-1, 1] on 32 pixels, so the
/// edge sits at film x = 16 + 0.3·16 = 20.8, inside pixel column 20).
/// Only the two columns whose corner squares straddle it refine; the
/// pixel's value is its white fraction to within the trapezoid rule's
/// error on the finest cells: the cell column holding the edge is given
/// half its width whatever the true split, so the error is at most half a
/// cell, 2^−depth/2 of the pixel.
#[test]
fn adaptive_refines_at_an_edge_and_estimates_coverage() {
    let material = r#"color = [1.0, 1.0, 1.0]
texture = { kind = "checker", size = 100.0, color = [0.0, 0.0, 0.0], origin = [0.3, -50.0, 0.0], u_axis = [1.0, 0.0, 0.0], v_axis = [0.0, 1.0, 0.0] }"#;
    for depth in [1u32, 2, 3, 4] {
        let s = card(
            32,
            material,
            &with_sampler(&format!("adaptive:0.1:{depth}")),
        );
        let (film, _) = render::<_, Counters>(&s, &Whitted, Some(2));
        let edge_x = 20.8f32;
        for y in 0..32 {
            for x in 0..32 {
                let p = film.pixel(x, y);
                let straddles = (x as f32) < edge_x && edge_x < (x + 1) as f32;
                if straddles {
                    assert!(
                        p.count > 4,
                        "depth {depth}: pixel ({x}, {y}) did not refine"
                    );
                    // Left of the edge (u < 0.3, within the square whose
                    // parity is odd) is black: the white fraction is 0.2.
                    let white = (x + 1) as f32 - edge_x;
                    let tol = 0.5 / (1u32 << depth) as f32 + 1e-5;
                    assert!(
                        (p.mean.x - white).abs() <= tol,
                        "depth {depth}: pixel ({x}, {y}) = {} for coverage {white} (tol {tol})",
                        p.mean.x
                    );
                } else if x + 1 < 20 || x > 21 {
                    assert!(p.count <= 4, "pixel ({x}, {y}) refined away from the edge");
                }
            }
        }
    }
}

/// The adaptive sampler's image, counts and per-pixel costs do not depend
/// on the thread count, and the per-pixel costs sum to the totals.
#[test]
fn adaptive_is_deterministic_and_its_costs_add_up() {
    let overrides = Overrides {
        width: Some(64),
        height: Some(48),
        sampler: Some(Sampler::parse("adaptive:0.05:3").unwrap()),
        ..Default::default()
    };
    let s = load_scene(
        &raylab_testkit::repo_path("data/scenes/s1-spheres.toml"),
        &overrides,
    )
    .unwrap();
    let (a, ca) = render::<_, Counters>(&s, &Whitted, Some(1));
    let (b, cb) = render::<_, Counters>(&s, &Whitted, Some(2));
    assert_eq!(ca, cb);
    assert_eq!(bits(&a), bits(&b));
    let counts = |f: &Film| f.pixels.iter().map(|p| p.count).collect::<Vec<_>>();
    assert_eq!(counts(&a), counts(&b));
    let (c, total, per_pixel) = render_with_costs(&s, &Whitted, Some(2));
    assert_eq!(bits(&a), bits(&c));
    let mut sum = Counters::default();
    for p in &per_pixel {
        sum += *p;
    }
    assert_eq!(sum, total);
    assert_eq!(
        total.camera_rays,
        a.pixels.iter().map(|p| u64::from(p.count)).sum::<u64>()
    );
    // Edges exist in the S1 scene, so some pixels refined: more rays than
    // the lattice, far fewer than OGSS 8×8 everywhere.
    let lattice = 65 * 49;
    assert!(total.camera_rays > lattice && total.camera_rays < 64 * 48 * 16);
}

/// Wider filters keep a constant image constant (they divide by the sum of
/// the weights), and agree with a direct computation of Σw·L/Σw from the
/// samples regenerated here.
#[test]
fn filters_normalise_and_match_a_direct_computation() {
    let flat = card(12, "color = [0.25, 0.5, 1.0]", &Overrides::default());
    let zone = r#"color = [1.0, 1.0, 1.0]
texture = { kind = "zone_plate", k = 40.0, color = [0.0, 0.0, 0.0], u_axis = [1.0, 0.0, 0.0], v_axis = [0.0, 1.0, 0.0] }"#;
    for filter in [Filter::Tent, Filter::Mitchell] {
        let o = Overrides {
            sampler: Some(Sampler::parse("jitter:3").unwrap()),
            filter: Some(filter),
            ..Default::default()
        };
        let mut s = flat.clone();
        s.settings.sampler = o.sampler.unwrap();
        s.settings.filter = filter;
        let (film, _) = render::<_, Counters>(&s, &Whitted, Some(2));
        let img = film.image();
        // Σw·c/Σw = c up to f32 rounding of the sums (≈ 1e-7 relative).
        for v in img.iter() {
            assert!(
                [0.25f32, 0.5, 1.0].iter().any(|c| (v - c).abs() < 1e-5),
                "{filter:?}: {v}"
            );
        }

        let s = card(16, zone, &o);
        let (film, _) = render::<_, Counters>(&s, &Whitted, Some(2));
        let (f1, _) = render::<_, Counters>(&s, &Whitted, Some(1));
        assert_eq!(
            bits(&film),
            bits(&f1),
            "{filter:?}: thread count changed the image"
        );
        let img = film.image();
        let r = filter.radius();
        for (px, py) in [(0u32, 0u32), (7, 9), (15, 3), (15, 15)] {
            let (cx, cy) = (px as f64 + 0.5, py as f64 + 0.5);
            let (mut sum, mut wsum) = (0.0f64, 0.0f64);
            for qy in 0..16u32 {
                for qx in 0..16u32 {
                    for i in 0..9 {
                        let off = s.settings.sampler.sample(qx, qy, i, s.settings.seed);
                        let (x, y) = (qx as f32 + off.x, qy as f32 + off.y);
                        let (dx, dy) = (x as f64 - cx, y as f64 - cy);
                        if dx.abs() >= r as f64 || dy.abs() >= r as f64 {
                            continue;
                        }
                        let wt = f64::from(filter.weight(dx as f32, dy as f32));
                        let ray = s.camera.generate_ray(x, y);
                        let hit = s
                            .intersect(&ray, f32::INFINITY, &mut raylab::stats::NoStats)
                            .unwrap();
                        let v = s.materials[0].color_at(hit.point).x;
                        sum += wt * f64::from(v);
                        wsum += wt;
                    }
                }
            }
            let want = sum / wsum;
            let got = f64::from(img[[py as usize, px as usize, 0]]);
            // f32 accumulation of ≤ 36·9 terms of size ≤ 1: ≈ 1e-5.
            assert!(
                (got - want).abs() < 1e-4,
                "{filter:?} pixel ({px}, {py}): {got} vs {want}"
            );
        }
    }
}

/// The zone plate through pixel-centre samples is ½(1 + sin(k·r²)) at the
/// ray's hit point, computed here in f64 from the camera geometry.
/// Tolerance: the f32 hit point is off by ~1e-7 relative, and the
/// texture's slope 2kr ≤ 2·300·1.5 = 900 turns that into ≤ 1e-4, plus f32
/// evaluation of sin at arguments up to k·r² ≈ 600 (error ≈ 600·6e-8):
/// 1e-3 is safely above both and far below a wrong formula's errors.
#[test]
fn zone_plate_matches_its_formula() {
    let s = load_scene(
        &raylab_testkit::repo_path("data/scenes/aa/zone-plate.toml"),
        &Overrides {
            width: Some(64),
            height: Some(64),
            ..Default::default()
        },
    )
    .unwrap();
    let (film, _) = render::<_, Counters>(&s, &Whitted, Some(2));
    for py in (0..64).step_by(7) {
        for px in (0..64).step_by(5) {
            // Head-on camera at z = 2, view [-1, 1]²: the centre of pixel
            // (px, py) looks at x = (px + ½)/32 − 1, y = 1 − (py + ½)/32.
            let x = (px as f64 + 0.5) / 32.0 - 1.0;
            let y = 1.0 - (py as f64 + 0.5) / 32.0;
            let want = 0.5 * (1.0 + (300.0 * (x * x + y * y)).sin());
            let got = f64::from(film.pixel(px, py).mean.x);
            assert!(
                (got - want).abs() < 1e-3,
                "pixel ({px}, {py}): {got} vs {want}"
            );
        }
    }
}

/// Bad textures and filters in scene files are errors naming the line.
#[test]
fn bad_textures_and_filters_name_the_line() {
    let base = "[image]\nwidth = 4\nheight = 4\n[camera]\neye = [0.0, 0.0, 2.0]\n\
                look_at = [0.0, 0.0, 0.0]\nfov = 40.0\n";
    let cases = [
        (
            "[materials.m]\ntexture = { kind = \"checker\", size = -1.0, color = [0.0, 0.0, 0.0] }\n",
            "`size` must be positive",
        ),
        (
            "[materials.m]\ntexture = { kind = \"stripes\", size = 1.0 }\n",
            "stripes",
        ),
        ("[render]\nfilter = \"gauss\"\n", "unknown filter `gauss`"),
        ("[render]\nsampler = \"adaptive:2:99\"\n", "adaptive depth"),
    ];
    for (extra, expect) in cases {
        let text = format!("{base}{extra}");
        let err = parse_scene(&text, Path::new("bad.toml"), &Overrides::default())
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(err.contains("bad.toml:"), "{err}");
        assert!(err.contains(expect), "expected `{expect}` in: {err}");
    }
}

/// The `aa_images` study end to end: the reference is rendered once and
/// reused, rows carry finite metrics, more samples give less error, the
/// error spectra and their overlay figure are written, and a bad
/// reference sampler is refused before anything runs.
#[test]
fn aa_images_study_measures_against_a_cached_reference() {
    use raylab_lab::experiment::{run_experiment, ExperimentOptions};
    let dir = tempfile::tempdir().unwrap();
    let scene = raylab_testkit::repo().join("data/scenes/aa/zone-plate.toml");
    let manifest = format!(
        "name = \"aa\"\nkind = \"aa_images\"\nrepeats = 1\nwarmup = 0\n[fixed]\n\
         scene = {scene:?}\nresolution = \"32x32\"\nreference = \"jitter:8\"\n\
         [[sweep]]\nname = \"spp\"\nsampler = [\"ogss:1\", \"ogss:4\", \"jitter:4\", \"adaptive\"]\n"
    );
    let path = dir.path().join("aa.toml");
    std::fs::write(&path, &manifest).unwrap();
    let out = dir.path().join("out");
    let opts = ExperimentOptions {
        quick: false,
        resume: false,
        out_dir: Some(out.clone()),
        threads: Some(2),
        ..ExperimentOptions::default()
    };
    run_experiment(&path, &opts).unwrap();
    let reference = out.join("references/zone-plate-32x32-jitter8.exr");
    let modified = std::fs::metadata(&reference).unwrap().modified().unwrap();
    let mut rdr = csv::Reader::from_path(out.join("data.csv")).unwrap();
    let headers = rdr.headers().unwrap().clone();
    let col = |name: &str| headers.iter().position(|h| h == name).unwrap();
    let rows: Vec<csv::StringRecord> = rdr.records().map(Result::unwrap).collect();
    assert_eq!(rows.len(), 4);
    let mse = |i: usize| rows[i][col("mse")].parse::<f64>().unwrap();
    for (i, r) in rows.iter().enumerate() {
        assert!(mse(i).is_finite() && mse(i) > 0.0, "{r:?}");
        assert!(out.join(&r[col("error_spectrum_csv")]).is_file());
    }
    // OGSS 4×4 resolves the zone plate far better than one centre sample.
    assert!(mse(1) < 0.5 * mse(0), "{} vs {}", mse(1), mse(0));
    assert_eq!(&rows[1][col("rays_per_pixel")], "16.000000");
    assert!(out
        .join("aa-error-spectrum-spp-zone-plate-16spp.png")
        .is_file());
    // Run again: the reference is read, not rendered again.
    std::fs::remove_file(out.join("data.csv")).unwrap();
    run_experiment(&path, &opts).unwrap();
    assert_eq!(
        std::fs::metadata(&reference).unwrap().modified().unwrap(),
        modified
    );

    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, manifest.replace("jitter:8", "adaptive")).unwrap();
    let err = run_experiment(&bad, &opts).unwrap_err().to_string();
    assert!(err.contains("reference"), "{err}");
}
