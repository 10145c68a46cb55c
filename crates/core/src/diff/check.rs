//! Finite differences, the check of the derivatives, written once.
//!
//! The central difference (I(p + h) − I(p − h)) / 2h comes from two
//! ordinary `f32` renders of the scene with the parameter's value changed
//! in its description (through the parameter table) and the scene built
//! again: a numerical derivative of the very code the dual numbers
//! differentiate (the scene builder and the renderer), sharing none of the
//! derivative code itself. Both renders use the scene's seed (common
//! random numbers), so their noise largely cancels in the difference.
//!
//! **The step.** The central difference's error is about
//! h²·|I‴|/6 (truncation) + ε·|I|/h (round-off of the two renders, ε the
//! `f32` unit round-off 2⁻²³), smallest at h ≈ (3ε|I|/|I‴|)^⅓. Taking the
//! parameter's own size as the scale on which I varies (|I|/|I‴| ≈ p²,
//! at least 1), the rule is h = ε^⅓ · max(|p|, 1) ≈ 4.9e-3 · max(|p|, 1)
//! ([`default_step`]). The step actually used is the one the `f32` values
//! realise, ((p + h) − (p − h))/2 after rounding to `f32`.
//!
//! **Edges.** Away from edges the image is smooth in the parameter and the
//! difference converges to the interior derivative; at silhouettes and
//! shadow or refraction boundaries it sees the boundary move, which forward
//! mode does not. [`edge_mask`] flags those pixels (by comparing the
//! differences at h and h/2, see there) so that the per-pixel comparison
//! can leave them out.

use super::params::default_step;
use super::render::Gradients;
use super::DiffError;
use crate::film::LinearImage;
use crate::integrator::IntegratorKind;
use crate::io::scene_file::SceneSource;
use crate::scene::param::ParamId;
use crate::scene::Scene;
use crate::stats::NoStats;
use glam::Vec2;

/// The renders a check makes: the integrator, and the threads (`None`:
/// all cores).
#[derive(Clone, Copy, Debug)]
pub struct Renderer {
    pub integrator: IntegratorKind,
    pub threads: Option<usize>,
}

impl Renderer {
    /// The image of `scene`.
    fn image(&self, scene: &Scene) -> Result<LinearImage, DiffError> {
        let (film, _) = self
            .integrator
            .render::<NoStats>(scene, self.threads)
            .map_err(DiffError::Render)?;
        Ok(film.image())
    }
}

/// The step of the central difference for parameter `p` of `source`'s
/// scene: `step`, or the default rule of the module docs.
pub fn step_for(source: &SceneSource, p: ParamId, step: Option<f32>) -> f32 {
    step.unwrap_or_else(|| default_step(source.description.value(p)))
}

/// A central difference of one parameter.
#[derive(Clone, Debug)]
pub struct Difference {
    /// The step realised by the `f32` file values.
    pub h: f32,
    /// (I(p + h) − I(p − h)) / 2h per pixel and channel (row-major RGB).
    pub per_pixel: Vec<f32>,
    /// The same with half the step, for [`edge_mask`]'s smoothness test.
    pub per_pixel_half: Vec<f32>,
    /// The image I(p) itself, for the round-off bound.
    pub image: Vec<f32>,
    /// The difference of the image mean, with step h.
    pub image_mean: f64,
    /// The scenes at p + h and p − h, for [`edge_mask`].
    pub scenes: [Scene; 2],
}

/// The scene of `source` with `p` set to `v` (its description changed
/// through the parameter table, then built); an error says which value
/// failed and why.
fn moved(source: &SceneSource, p: ParamId, v: f32) -> Result<Scene, DiffError> {
    let mut desc = source.description.clone();
    desc.set_value(p, v);
    source.build_from(&desc).map_err(|e| {
        DiffError::Step(format!(
            "{}: {} set to {v} for the central difference: {} (the difference needs \
             p ± h in range: give a smaller step with `fd:H`)",
            source.path.display(),
            source.description.param_name(p),
            e.message
        ))
    })
}

/// Check, without rendering, that the scene still builds with `p` set to
/// p ± h (a colour at 0 cannot go below it, a radius must stay
/// positive…), so that a check fails before anything is written.
pub fn check_step(source: &SceneSource, p: ParamId, h: f32) -> Result<(), DiffError> {
    let value = source.description.value(p);
    for v in [value - h, value + h] {
        moved(source, p, v)?;
    }
    Ok(())
}

/// One central difference of the image in `p`: the two renders at p ± h.
pub struct Step {
    /// (I(p + h) − I(p − h)) / 2h per pixel and channel (row-major RGB).
    pub per_pixel: Vec<f32>,
    /// The same for the image mean.
    pub image_mean: f64,
    /// The scenes at p + h and p − h.
    pub scenes: [Scene; 2],
    /// The step realised by the `f32` file values.
    pub h: f32,
}

/// The central difference of the image in `p` with step `step` alone (the
/// scene of `source` rendered by `renderer`): the finite-difference
/// *estimator*, two renders with the scene's seed.
pub fn difference_step(
    source: &SceneSource,
    p: ParamId,
    step: f32,
    renderer: Renderer,
) -> Result<Step, DiffError> {
    let value = source.description.value(p);
    let (vp, vm) = (value + step, value - step);
    let plus = moved(source, p, vp)?;
    let minus = moved(source, p, vm)?;
    let h = 0.5 * (vp - vm);
    if h <= 0.0 {
        return Err(DiffError::Step(format!(
            "step {step} is too small for `{}` = {value} in f32",
            source.description.param_name(p)
        )));
    }
    let (ip, im) = (renderer.image(&plus)?, renderer.image(&minus)?);
    let per_pixel = ip
        .iter()
        .zip(im.iter())
        .map(|(a, b)| (a - b) / (2.0 * h))
        .collect();
    let mean =
        |img: &LinearImage| img.iter().map(|&x| f64::from(x)).sum::<f64>() / img.len() as f64;
    Ok(Step {
        per_pixel,
        image_mean: (mean(&ip) - mean(&im)) / (2.0 * f64::from(h)),
        scenes: [plus, minus],
        h,
    })
}

/// Render the central difference of the image in `p` with step `h` (the
/// scene of `source` rendered by `renderer`): renders at p ± h and
/// p ± h/2, and the image at p.
pub fn central_difference(
    source: &SceneSource,
    p: ParamId,
    h: f32,
    renderer: Renderer,
) -> Result<Difference, DiffError> {
    let full = difference_step(source, p, h, renderer)?;
    let half = difference_step(source, p, 0.5 * h, renderer)?;
    let base = moved(source, p, source.description.value(p))?;
    Ok(Difference {
        h: full.h,
        per_pixel: full.per_pixel,
        per_pixel_half: half.per_pixel,
        image: renderer.image(&base)?.iter().copied().collect(),
        image_mean: full.image_mean,
        scenes: full.scenes,
    })
}

/// Pixels where the image is not smooth in the parameter, row-major.
///
/// A pixel is flagged when the central differences with steps h and h/2
/// disagree by more than 5% of the larger, plus 1% of the image's mean
/// |difference|, plus eight times the round-off bound 2ε·|I|/h (ε the f32
/// unit round-off): in smooth parts they differ by O(h²), while a boundary
/// that crosses the pixel's samples within ±h contributes a jump/2h to one
/// and jump/h or nothing to the other. This finds silhouettes, shadow
/// edges, and edges seen in mirrors or through glass alike. A pixel is
/// also flagged when the object its camera-ray samples hit first is not
/// the same for all of them, differs from a neighbour's, or changes
/// between `scenes` (the scene and its two displaced copies): silhouettes
/// that a smooth-looking difference can hide. The flags are then widened
/// by one pixel.
pub fn edge_mask(scenes: &[&Scene], fd: &Difference) -> Vec<bool> {
    let cam = &scenes[0].camera;
    let (w, h) = (cam.width as usize, cam.height as usize);
    let mut edge = vec![false; w * h];
    let grey = |v: &[f32], i: usize| (v[3 * i] + v[3 * i + 1] + v[3 * i + 2]) / 3.0;
    let scale = (0..w * h)
        .map(|i| grey(&fd.per_pixel, i).abs())
        .sum::<f32>()
        / (w * h).max(1) as f32;
    for (i, e) in edge.iter_mut().enumerate() {
        for c in 0..3 {
            let (a, b) = (fd.per_pixel[3 * i + c], fd.per_pixel_half[3 * i + c]);
            let roundoff = 2.0 * f32::EPSILON * fd.image[3 * i + c].abs().max(1e-3) / fd.h;
            if (a - b).abs() > 0.05 * a.abs().max(b.abs()) + 0.01 * scale + 8.0 * roundoff {
                *e = true;
            }
        }
    }
    let mut first = vec![u32::MAX; w * h];
    for (si, scene) in scenes.iter().enumerate() {
        let sampler = scene.settings.sampler;
        let seed = scene.settings.seed;
        let mut ids = vec![u32::MAX; w * h];
        for py in 0..h {
            for px in 0..w {
                let mut id = None;
                for index in 0..sampler.spp() {
                    let off = sampler.sample(px as u32, py as u32, index, seed);
                    let pos = Vec2::new(px as f32, py as f32) + off;
                    let ray = scene.camera.generate_ray(pos.x, pos.y);
                    let o = scene
                        .intersect(&ray, scene.settings.max_distance, &mut NoStats)
                        .map_or(u32::MAX - 1, |hit| hit.object);
                    match id {
                        None => id = Some(o),
                        Some(i) if i != o => edge[py * w + px] = true,
                        _ => {}
                    }
                }
                ids[py * w + px] = id.unwrap_or(u32::MAX - 1);
            }
        }
        for i in 0..w * h {
            if si == 0 {
                first[i] = ids[i];
            } else if first[i] != ids[i] {
                edge[i] = true;
            }
        }
        for py in 0..h {
            for px in 0..w {
                let i = py * w + px;
                if (px + 1 < w && ids[i] != ids[i + 1]) || (py + 1 < h && ids[i] != ids[i + w]) {
                    edge[i] = true;
                    edge[if px + 1 < w && ids[i] != ids[i + 1] {
                        i + 1
                    } else {
                        i + w
                    }] = true;
                }
            }
        }
    }
    // Widen by one pixel.
    let mut wide = edge.clone();
    for py in 0..h {
        for px in 0..w {
            if edge[py * w + px] {
                for (dx, dy) in [
                    (-1i64, 0i64),
                    (1, 0),
                    (0, -1),
                    (0, 1),
                    (-1, -1),
                    (1, 1),
                    (-1, 1),
                    (1, -1),
                ] {
                    let (x, y) = (px as i64 + dx, py as i64 + dy);
                    if x >= 0 && y >= 0 && (x as usize) < w && (y as usize) < h {
                        wide[y as usize * w + x as usize] = true;
                    }
                }
            }
        }
    }
    wide
}

/// How forward mode and the central difference compare for one parameter.
#[derive(Clone, Debug, PartialEq)]
pub struct Comparison {
    /// The image mean's derivative by AD and by the difference.
    pub ad_mean: f64,
    pub fd_mean: f64,
    /// |AD − FD| / |FD| of the image mean (∞ when FD is 0 and AD is not).
    pub mean_rel_error: f64,
    /// The step used.
    pub h: f32,
    /// Share of pixels flagged as near an edge.
    pub edge_fraction: f64,
    /// 50th, 90th and 99th percentiles, over the pixels away from edges
    /// whose derivative is not 0 by both estimates, of |AD − FD| (channel
    /// mean) divided by those pixels' mean |FD| (NaN when there are none).
    pub interior_error: [f64; 3],
    /// AD − FD per pixel (channel mean), row-major.
    pub difference: Vec<f32>,
    /// Share of all pixels, and of the pixels near an edge, where
    /// |AD − FD| ≤ 4 standard errors of AD + 10⁻³ of the image's mean
    /// |FD| (the difference's own error: O(h²) and the noise of two
    /// renders that share their random numbers). With the boundary term
    /// both should be at least 0.99 when FD is converged; without it the
    /// edge pixels fail.
    pub within_4se: f64,
    pub within_4se_edges: f64,
}

/// Compare the AD channel-mean image `ad_grey` (with per-pixel standard
/// errors `ad_se`) and image-mean derivative `ad_mean` with the difference
/// `fd`; the percentiles leave out pixels in `edges`.
pub fn compare(
    ad_grey: &[f32],
    ad_se: &[f32],
    ad_mean: f64,
    fd: &Difference,
    edges: &[bool],
) -> Comparison {
    let fd_grey: Vec<f32> = fd
        .per_pixel
        .chunks_exact(3)
        .map(|c| (c[0] + c[1] + c[2]) / 3.0)
        .collect();
    let difference: Vec<f32> = ad_grey.iter().zip(&fd_grey).map(|(a, f)| a - f).collect();
    // Interior pixels the parameter affects (by either estimate).
    let interior: Vec<usize> = (0..edges.len())
        .filter(|&i| !edges[i] && (ad_grey[i] != 0.0 || fd_grey[i] != 0.0))
        .collect();
    let scale = interior
        .iter()
        .map(|&i| f64::from(fd_grey[i]).abs())
        .sum::<f64>()
        / interior.len().max(1) as f64;
    let mut errs: Vec<f64> = interior
        .iter()
        .map(|&i| f64::from(difference[i]).abs() / scale.max(f64::MIN_POSITIVE))
        .collect();
    let p = crate::math::percentiles(&mut errs, &[50.0, 90.0, 99.0]);
    let all_scale =
        fd_grey.iter().map(|&x| f64::from(x).abs()).sum::<f64>() / fd_grey.len().max(1) as f64;
    let ok =
        |i: usize| f64::from(difference[i]).abs() <= 4.0 * f64::from(ad_se[i]) + 1e-3 * all_scale;
    let share = |pixels: &mut dyn Iterator<Item = usize>| {
        let (mut n, mut good) = (0usize, 0usize);
        for i in pixels {
            n += 1;
            good += usize::from(ok(i));
        }
        if n == 0 {
            1.0
        } else {
            good as f64 / n as f64
        }
    };
    let within_4se = share(&mut (0..edges.len()));
    let within_4se_edges = share(&mut (0..edges.len()).filter(|&i| edges[i]));
    let mean_rel_error = if fd.image_mean == 0.0 {
        if ad_mean == 0.0 {
            0.0
        } else {
            f64::INFINITY
        }
    } else {
        (ad_mean - fd.image_mean).abs() / fd.image_mean.abs()
    };
    Comparison {
        ad_mean,
        fd_mean: fd.image_mean,
        mean_rel_error,
        h: fd.h,
        edge_fraction: edges.iter().filter(|&&e| e).count() as f64 / edges.len().max(1) as f64,
        interior_error: [p[0], p[1], p[2]],
        difference,
        within_4se,
        within_4se_edges,
    }
}

/// The whole check of parameter `g.params[i]`: the central difference with
/// step `h` ([`central_difference`]), the [`edge_mask`] and the
/// [`compare`]son with the AD images `g` of `scene` (the scene of
/// `source`).
pub fn check_param(
    source: &SceneSource,
    scene: &Scene,
    g: &Gradients,
    i: usize,
    h: f32,
    renderer: Renderer,
) -> Result<Comparison, DiffError> {
    let fd = central_difference(source, g.params[i], h, renderer)?;
    let edges = edge_mask(&[scene, &fd.scenes[0], &fd.scenes[1]], &fd);
    Ok(compare(
        &g.grey(i),
        &g.grey_se(i),
        g.image_mean(i).0,
        &fd,
        &edges,
    ))
}
