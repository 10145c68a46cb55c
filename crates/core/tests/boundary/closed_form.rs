//! A disc's pixel coverage: the boundary term against its closed form.

use super::*;

/// A white sphere of radius 1 at distance 10 on the axis of a 24×24
/// camera with a 20° view, lit by ambient light only over a black
/// background: each pixel is the share of its square the sphere's image
/// covers, a disc of radius R = tan α / tan 10° · 12 pixels (sin α = r/D)
/// centred on the image.
const DISC: &str = r#"
[image]
width = 24
height = 24
[camera]
eye = [0.0, 0.0, 10.0]
look_at = [0.0, 0.0, 0.0]
fov = 20.0
[render]
background = [0.0, 0.0, 0.0]
ambient = [1.0, 1.0, 1.0]
[materials.white]
color = [1.0, 1.0, 1.0]
ambient = 1.0
diffuse = 0.0
specular = 0.0
[[sphere]]
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "white"
"#;

/// ∫ √(R² − x²) dx.
fn g(x: f64, r: f64) -> f64 {
    let x = x.clamp(-r, r);
    0.5 * (x * (r * r - x * x).max(0.0).sqrt() + r * r * (x / r).asin())
}

/// The area of the disc of radius `r` centred at the origin inside the
/// rectangle [x0, x1] × [y0, y1], in closed form: over the pieces of
/// [x0, x1] between the points where the circle crosses y0, y1 or ends,
/// the covered height is one of y1 − y0, h − y0, y1 + h or 2h
/// (h = √(R² − x²)), each integrated by [`g`].
fn disc_in_rect(r: f64, x0: f64, x1: f64, y0: f64, y1: f64) -> f64 {
    let mut cuts = vec![x0, x1, -r, r];
    for y in [y0, y1] {
        if y.abs() < r {
            let c = (r * r - y * y).sqrt();
            cuts.extend([-c, c]);
        }
    }
    let (a, b) = (x0.max(-r), x1.min(r));
    if a >= b {
        return 0.0;
    }
    let mut cuts: Vec<f64> = cuts.into_iter().filter(|&c| c >= a && c <= b).collect();
    cuts.sort_by(f64::total_cmp);
    let mut area = 0.0;
    for w in cuts.windows(2) {
        let (u, v) = (w[0], w[1]);
        if v <= u {
            continue;
        }
        let m = 0.5 * (u + v);
        let h = (r * r - m * m).max(0.0).sqrt();
        let (top_h, bottom_h) = (h < y1, -h > y0);
        let (top, bottom) = (h.min(y1), (-h).max(y0));
        if top <= bottom {
            continue;
        }
        let hg = g(v, r) - g(u, r);
        area += match (top_h, bottom_h) {
            (true, true) => 2.0 * hg,
            (true, false) => hg - y0 * (v - u),
            (false, true) => y1 * (v - u) + hg,
            (false, false) => (y1 - y0) * (v - u),
        };
    }
    area
}

#[test]
fn the_closed_form_is_the_discs_area() {
    // The whole disc, half of it, a quarter, and a square inside it.
    let r = 2.5;
    let pi = std::f64::consts::PI;
    assert!((disc_in_rect(r, -3.0, 3.0, -3.0, 3.0) - pi * r * r).abs() < 1e-12);
    assert!((disc_in_rect(r, 0.0, 3.0, -3.0, 3.0) - pi * r * r / 2.0).abs() < 1e-12);
    assert!((disc_in_rect(r, 0.0, 3.0, 0.0, 3.0) - pi * r * r / 4.0).abs() < 1e-12);
    assert!((disc_in_rect(r, -1.0, 1.0, -1.0, 1.0) - 4.0).abs() < 1e-12);
}

/// Per pixel, the derivative of the disc's coverage by its image radius
/// and by its image centre's x, by central differences of the closed form
/// (a smooth function of both, so a step of 10⁻⁵ pixel is exact to ~1e-9).
fn coverage_derivatives(r_px: f64, w: usize) -> (Vec<f64>, Vec<f64>) {
    let c = w as f64 / 2.0;
    let cover = |r: f64, cx: f64, px: usize, py: usize| {
        let (x0, y0) = (px as f64 - cx, py as f64 - c);
        disc_in_rect(r, x0, x0 + 1.0, y0, y0 + 1.0)
    };
    let h = 1e-5;
    let mut by_r = Vec::new();
    let mut by_x = Vec::new();
    for py in 0..w {
        for px in 0..w {
            by_r.push((cover(r_px + h, c, px, py) - cover(r_px - h, c, px, py)) / (2.0 * h));
            by_x.push((cover(r_px, c + h, px, py) - cover(r_px, c - h, px, py)) / (2.0 * h));
        }
    }
    (by_r, by_x)
}

#[test]
fn a_discs_coverage_derivative_matches_its_closed_form() {
    let (scene, file) = load(DISC, "jitter:6");
    let p = params(
        &["sphere[0].radius", "sphere[0].center[0]"],
        &file.description,
    );
    let g = gradients(
        &scene,
        &file.description,
        &p,
        IntegratorKind::Whitted,
        Visibility::Full,
    );
    // The disc's image: tan α = r/√(D² − r²); pixels per unit of the near
    // plane's tangent: 12 / tan 10°.
    let (d, r) = (10.0f64, 1.0f64);
    let scale = 12.0 / 10f64.to_radians().tan();
    let r_px = r / (d * d - r * r).sqrt() * scale;
    let dr_px = d * d / (d * d - r * r).powf(1.5) * scale;
    // A sideways move of the centre by δ moves the image by δ/D·scale to
    // first order (the image stays a circle to first order on the axis).
    let dx_px = scale / d;
    let (by_r, by_x) = coverage_derivatives(r_px, 24);
    for (k, (truth, chain)) in [(by_r, dr_px), (by_x, dx_px)].into_iter().enumerate() {
        let (ad, se) = (g.grey(k), g.grey_se(k));
        let mut good = 0;
        let (mut sum_ad, mut sum_truth, mut var) = (0.0, 0.0, 0.0);
        for i in 0..ad.len() {
            let t = truth[i] * chain;
            let (a, s) = (f64::from(ad[i]), f64::from(se[i]));
            good += usize::from((a - t).abs() <= 4.0 * s + 1e-6);
            sum_ad += a;
            sum_truth += t;
            var += s * s;
        }
        let share = good as f64 / ad.len() as f64;
        assert!(
            share >= 0.99,
            "{}: {share} of pixels within 4 SE",
            file.description.param_name(p[k])
        );
        assert!(
            (sum_ad - sum_truth).abs() <= 4.0 * var.sqrt() + 1e-6,
            "{}: Σ AD {sum_ad}, closed form {sum_truth} ± {}",
            file.description.param_name(p[k]),
            var.sqrt()
        );
        // Without the boundary term these derivatives are 0.
        assert!(g.boundary.planes.mean[k].iter().any(|&v| v != 0.0));
    }
    // The radius's total: the circumference times dR/dr.
    let total: f64 = g.grey(0).iter().map(|&v| f64::from(v)).sum();
    let want = 2.0 * std::f64::consts::PI * r_px * dr_px;
    assert!((total - want).abs() < 0.02 * want, "{total} vs {want}");
    assert!(g.boundary.stats.primary_curves == 1 && g.boundary.stats.landed > 0);
}
