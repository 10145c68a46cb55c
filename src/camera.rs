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

use crate::math::{Ray, Vec3};

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
    #[error("eye and look_at coincide")]
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
}

impl Camera {
    /// `fov_deg` is the vertical view angle θ in degrees; `aspect` is W/H
    /// (usually width/height, for square pixels).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        eye: Vec3,
        look_at: Vec3,
        up: Vec3,
        fov_deg: f32,
        aspect: f32,
        near: f32,
        width: u32,
        height: u32,
    ) -> Result<Self, CameraError> {
        if width == 0 || height == 0 {
            return Err(CameraError::Size(width, height));
        }
        if !(fov_deg > 0.0 && fov_deg < 180.0) {
            return Err(CameraError::ViewAngle(fov_deg));
        }
        if !(near > 0.0 && near.is_finite()) {
            return Err(CameraError::Near(near));
        }
        if !(aspect > 0.0 && aspect.is_finite()) {
            return Err(CameraError::Aspect(aspect));
        }
        let n = (eye - look_at)
            .try_normalize()
            .ok_or(CameraError::EyeAtTarget)?;
        let u = up.cross(n).try_normalize().ok_or(CameraError::UpParallel)?;
        let v = n.cross(u);
        let half_height = near * (0.5 * fov_deg.to_radians()).tan();
        Ok(Self {
            eye,
            u,
            v,
            n,
            near,
            half_height,
            half_width: half_height * aspect,
            width,
            height,
        })
    }

    // ANCHOR: generate_ray
    /// The ray through film position (x, y) in pixels, x to the right from
    /// the left edge, y down from the top edge. The direction is unit length
    /// so that `t` is a distance.
    #[inline]
    pub fn generate_ray(&self, x: f32, y: f32) -> Ray {
        let (w, h) = (self.half_width, self.half_height);
        let uc = -w + 2.0 * w * x / self.width as f32;
        let r = self.height as f32 - y;
        let vr = -h + 2.0 * h * r / self.height as f32;
        let dir = -self.near * self.n + uc * self.u + vr * self.v;
        Ray::new(self.eye, dir.normalize())
    }
    // ANCHOR_END: generate_ray
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_ray_looks_at_target_and_corners_span_the_view_angle() {
        let cam = Camera::new(
            Vec3::new(0.0, 0.0, 5.0),
            Vec3::ZERO,
            Vec3::Y,
            90.0,
            2.0,
            1.0,
            200,
            100,
        )
        .unwrap();
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
    fn rejects_degenerate_set_ups() {
        let c = |eye, at, up, fov| Camera::new(eye, at, up, fov, 1.0, 1.0, 8, 8);
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
