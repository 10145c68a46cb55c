//! The pinhole camera of S2 (after Hill, "Computer Graphics", 1990).
//!
//! The camera has an eye point and an orthonormal basis u (right), v (up),
//! n (backwards, from the look-at point towards the eye). The image lies on
//! the near plane at distance N in front of the eye, with half-height
//! H = N·tan(θ/2) for the vertical view angle θ and half-width W = H·aspect.
//! Pixel (c, r) of an nCols × nRows image maps to
//! u_c = −W + 2W·c/nCols, v_r = −H + 2H·r/nRows, and its ray is
//! eye + t·dir with dir = −N·n + u_c·u + v_r·v (S2). Here c and r are
//! continuous film coordinates, so a sampler can place samples anywhere in
//! the pixel; the pixel centre is (c + ½, r + ½). S2 counts rows from the
//! bottom; image files count from the top, so row `y` of the file is
//! r = nRows − y.
//!
//! The formulas are written once, over [`Real`], in [`Frame`]: the renders
//! evaluate them on `f32`, the derivative code on dual numbers (the image's
//! derivative with respect to the eye, the look-at point or the view angle).

use crate::math::{Ray, RayR, Real, ShowVec, Vec3, MAX_COORDINATE, V3};

/// The camera's eye, basis and near-plane rectangle, as functions of the
/// scene file's camera entries.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame<R> {
    pub eye: V3<R>,
    pub u: V3<R>,
    pub v: V3<R>,
    pub n: V3<R>,
    pub near: R,
    pub half_height: R,
    pub half_width: R,
}

impl<R: Real> Frame<R> {
    /// The frame of a camera at `eye` looking at `look_at` with vertical
    /// view angle `fov_deg` (degrees); `None` when eye and target coincide
    /// or `up` is parallel to the view (the caller has checked the
    /// scalars' ranges).
    pub fn new(
        eye: V3<R>,
        look_at: V3<R>,
        up: V3<R>,
        fov_deg: R,
        aspect: R,
        near: R,
    ) -> Result<Self, CameraError> {
        let unit = |v: V3<R>, e: CameraError| {
            let rcp = 1.0 / v.value().length();
            if rcp.is_finite() && rcp > 0.0 {
                Ok(v.normalize())
            } else {
                Err(e)
            }
        };
        let n = unit(eye - look_at, CameraError::EyeAtTarget)?;
        let u = unit(up.cross(n), CameraError::UpParallel)?;
        let v = n.cross(u);
        let rad = R::from_f32(std::f32::consts::PI / 180.0);
        let half_height = near * (R::from_f32(0.5) * (fov_deg * rad)).tan();
        Ok(Self {
            eye,
            u,
            v,
            n,
            near,
            half_height,
            half_width: half_height * aspect,
        })
    }

    // ANCHOR: generate_ray
    /// The ray through film position (x, y) in pixels of a `width` ×
    /// `height` image, x to the right from the left edge, y down from the
    /// top edge. The direction is unit length so that `t` is a distance.
    #[inline]
    pub fn ray(&self, x: f32, y: f32, width: u32, height: u32) -> RayR<R> {
        self.ray_at(R::from_f32(x), R::from_f32(y), width, height)
    }

    /// [`Frame::ray`] with the film position as a function of the
    /// parameters too (the same operations, so the same `f32` ray).
    #[inline]
    pub fn ray_at(&self, x: R, y: R, width: u32, height: u32) -> RayR<R> {
        let (w, h) = (self.half_width, self.half_height);
        let two = R::from_f32(2.0);
        let uc = -w + two * w * x / R::from_f32(width as f32);
        let r = R::from_f32(height as f32) - y;
        let vr = -h + two * h * r / R::from_f32(height as f32);
        let dir = self.n * -self.near + self.u * uc + self.v * vr;
        RayR::new(self.eye, dir.normalize())
    }
    // ANCHOR_END: generate_ray

    /// The film position (x, y) in pixels where point `p` appears: the
    /// inverse of [`Frame::ray`] (`None` for points not in front of the
    /// eye). Over dual numbers it is how a point's motion moves its image.
    pub fn project(&self, p: V3<R>, width: u32, height: u32) -> Option<(R, R)> {
        let d = p - self.eye;
        let depth = -d.dot(self.n);
        if depth.value() <= 0.0 {
            return None;
        }
        let s = self.near / depth;
        let (uc, vr) = (d.dot(self.u) * s, d.dot(self.v) * s);
        let two = R::from_f32(2.0);
        let x = (uc + self.half_width) * R::from_f32(width as f32) / (two * self.half_width);
        let r = (vr + self.half_height) * R::from_f32(height as f32) / (two * self.half_height);
        Some((x, R::from_f32(height as f32) - r))
    }
}

impl Frame<f32> {
    /// The same frame over another [`Real`], as constants.
    pub fn lift<R: Real>(&self) -> Frame<R> {
        let v = |x: V3<f32>| V3::from_vec3(x.value());
        Frame {
            eye: v(self.eye),
            u: v(self.u),
            v: v(self.v),
            n: v(self.n),
            near: R::from_f32(self.near),
            half_height: R::from_f32(self.half_height),
            half_width: R::from_f32(self.half_width),
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub eye: Vec3,
    pub u: Vec3,
    pub v: Vec3,
    pub n: Vec3,
    /// Near-plane distance N.
    pub near: f32,
    /// Half-height H and half-width W of the image on the near plane.
    pub half_height: f32,
    pub half_width: f32,
    /// Image size in pixels (nCols, nRows).
    pub width: u32,
    pub height: u32,
}

/// Why a camera could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CameraError {
    #[error("eye and look_at coincide (or lie too close for single precision)")]
    EyeAtTarget,
    #[error("up is parallel to the viewing direction")]
    UpParallel,
    #[error("view angle must be in (0, 180) degrees, got {0}")]
    ViewAngle(f32),
    #[error("near-plane distance must be positive and finite, got {0}")]
    Near(f32),
    #[error("aspect must be positive and finite, got {0}")]
    Aspect(f32),
    #[error("image size must be at least 1×1, got {0}×{1}")]
    Size(u32, u32),
    #[error("`{0}` must be finite, got {1}")]
    NotFinite(&'static str, Vec3),
    #[error("`{field}` = {v} lies beyond ±{MAX_COORDINATE:e}, the largest coordinate raylab's geometry may have", field = .0, v = ShowVec(*.1))]
    TooFar(&'static str, Vec3),
}

/// The camera as a scene file gives it: S2's eye, look-at point, up
/// vector, vertical view angle and near-plane distance, and the aspect
/// W/H of the image on the near plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraDesc {
    pub eye: Vec3,
    pub look_at: Vec3,
    pub up: Vec3,
    /// Vertical view angle θ in degrees.
    pub fov: f32,
    /// Near-plane distance N.
    pub near: f32,
    /// W/H; `None`: the image's width/height (square pixels).
    pub aspect: Option<f32>,
}

impl CameraDesc {
    /// The aspect W/H for an image of `width` × `height` pixels.
    pub fn aspect_for(&self, width: u32, height: u32) -> f32 {
        self.aspect.unwrap_or(width as f32 / height.max(1) as f32)
    }

    /// The numbers in range (the frame itself can still fail: eye at the
    /// target, up along the view).
    pub fn check(&self) -> Result<(), CameraError> {
        for (name, v) in [
            ("eye", self.eye),
            ("look_at", self.look_at),
            ("up", self.up),
        ] {
            if !v.is_finite() {
                return Err(CameraError::NotFinite(name, v));
            }
            if v.abs().max_element() > MAX_COORDINATE {
                return Err(CameraError::TooFar(name, v));
            }
        }
        if !(self.fov > 0.0 && self.fov < 180.0) {
            return Err(CameraError::ViewAngle(self.fov));
        }
        if !(self.near > 0.0 && self.near.is_finite()) {
            return Err(CameraError::Near(self.near));
        }
        match self.aspect {
            Some(a) if !(a > 0.0 && a.is_finite()) => Err(CameraError::Aspect(a)),
            _ => Ok(()),
        }
    }
}

impl Camera {
    /// The camera `desc` describes, for an image of `width` × `height`
    /// pixels.
    pub fn new(desc: &CameraDesc, width: u32, height: u32) -> Result<Self, CameraError> {
        if width == 0 || height == 0 {
            return Err(CameraError::Size(width, height));
        }
        desc.check()?;
        let aspect = desc.aspect_for(width, height);
        if !(aspect > 0.0 && aspect.is_finite()) {
            return Err(CameraError::Aspect(aspect));
        }
        let f = Frame::new(
            desc.eye.into(),
            desc.look_at.into(),
            desc.up.into(),
            desc.fov,
            aspect,
            desc.near,
        )?;
        Self::from_frame(&f, width, height)
    }

    /// The `f32` camera of frame `f` for an image of `width` × `height`
    /// pixels.
    pub fn from_frame(f: &Frame<f32>, width: u32, height: u32) -> Result<Self, CameraError> {
        if width == 0 || height == 0 {
            return Err(CameraError::Size(width, height));
        }
        Ok(Self {
            eye: f.eye.into(),
            u: f.u.into(),
            v: f.v.into(),
            n: f.n.into(),
            near: f.near,
            half_height: f.half_height,
            half_width: f.half_width,
            width,
            height,
        })
    }

    /// The camera's [`Frame`] in `f32`.
    #[inline]
    pub fn frame(&self) -> Frame<f32> {
        Frame {
            eye: self.eye.into(),
            u: self.u.into(),
            v: self.v.into(),
            n: self.n.into(),
            near: self.near,
            half_height: self.half_height,
            half_width: self.half_width,
        }
    }

    /// The ray through film position (x, y) in pixels ([`Frame::ray`]).
    #[inline]
    pub fn generate_ray(&self, x: f32, y: f32) -> Ray {
        self.frame().ray(x, y, self.width, self.height).value()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_ray_looks_at_target_and_corners_span_the_view_angle() {
        let desc = CameraDesc {
            eye: Vec3::new(0.0, 0.0, 5.0),
            look_at: Vec3::ZERO,
            up: Vec3::Y,
            fov: 90.0,
            near: 1.0,
            aspect: Some(2.0),
        };
        let cam = Camera::new(&desc, 200, 100).unwrap();
        let r = cam.generate_ray(100.0, 50.0);
        assert!((r.dir - -Vec3::Z).length() < 1e-6);
        // Top edge, centre column: 45° above the axis for θ = 90°.
        let top = cam.generate_ray(100.0, 0.0);
        assert!((top.dir.angle_between(-Vec3::Z).to_degrees() - 45.0).abs() < 1e-4);
        assert!(top.dir.y > 0.0);
        // Left edge: W = 2H, so tan(angle) = 2.
        let left = cam.generate_ray(0.0, 50.0);
        assert!((left.dir.x / -left.dir.z + 2.0).abs() < 1e-5);
    }

    #[test]
    fn project_inverts_the_ray() {
        let desc = CameraDesc {
            eye: Vec3::new(1.0, 2.0, 5.0),
            look_at: Vec3::new(0.3, 0.0, 0.0),
            up: Vec3::Y,
            fov: 50.0,
            near: 1.0,
            aspect: Some(1.5),
        };
        let cam = Camera::new(&desc, 96, 64).unwrap();
        let f = cam.frame();
        for (x, y) in [(0.0, 0.0), (47.3, 12.9), (95.5, 63.25)] {
            let ray = f.ray(x, y, 96, 64);
            let (px, py) = f.project(ray.at(7.5), 96, 64).unwrap();
            assert!((px - x).abs() < 1e-3 && (py - y).abs() < 1e-3, "{px} {py}");
        }
        assert_eq!(
            f.project(V3::from_vec3(Vec3::new(1.0, 2.0, 9.0)), 96, 64),
            None
        );
    }

    #[test]
    fn rejects_degenerate_set_ups() {
        let c = |eye, look_at, up, fov| {
            let desc = CameraDesc {
                eye,
                look_at,
                up,
                fov,
                near: 1.0,
                aspect: None,
            };
            Camera::new(&desc, 8, 8)
        };
        assert_eq!(
            c(Vec3::ZERO, Vec3::ZERO, Vec3::Y, 60.0),
            Err(CameraError::EyeAtTarget)
        );
        assert_eq!(
            c(Vec3::Y, Vec3::ZERO, Vec3::Y, 60.0),
            Err(CameraError::UpParallel)
        );
        assert_eq!(
            c(Vec3::Z, Vec3::ZERO, Vec3::Y, 180.0),
            Err(CameraError::ViewAngle(180.0))
        );
    }
}
