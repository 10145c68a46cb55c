//! Materials of S1/S2: the Phong local model (ambient, diffuse, specular)
//! plus Whitted's reflectivity and transparency with an index of refraction.
//!
//! The specular term is Phong's, (R·V)^shininess with R the light direction
//! mirrored about the normal (not Blinn–Phong's half vector), as in the
//! sources.
//!
//! A material may carry a procedural [`Texture`] that replaces its colour
//! at each hit point. The textures are the anti-aliasing test patterns
//! (checkerboard, zone plate): point-sampled on purpose, with no filtering,
//! so that the samplers alone decide how much they alias.

use crate::error::RangeError;
use crate::math::{Color, Real, Vec3, V3};
use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Material {
    /// Surface colour (diffuse and ambient reflectance), linear RGB.
    pub color: Color,
    /// Ambient coefficient k_a.
    pub ambient: f32,
    /// Diffuse coefficient k_d.
    pub diffuse: f32,
    /// Specular coefficient k_s.
    pub specular: f32,
    /// Phong exponent.
    pub shininess: f32,
    /// Colour of the specular highlight (white for dielectrics).
    pub specular_color: Color,
    /// Mirror reflection coefficient k_r in [0, 1].
    pub reflectivity: f32,
    /// Transmission coefficient k_t in [0, 1].
    pub transparency: f32,
    /// Index of refraction of the object's interior.
    pub ior: f32,
    /// Emitted radiance (for area lights in the path tracer; the Whitted
    /// integrator adds it as a constant term).
    pub emission: Color,
    /// A procedural pattern that replaces `color` at each point.
    pub texture: Option<Texture>,
}

/// A procedural surface pattern, evaluated at the hit point in a planar
/// coordinate system: u = (p − origin)·u_axis, v = (p − origin)·v_axis
/// (world x and z by default, which suits a ground plane). The pattern
/// mixes the material's `color` (value 1) and the texture's `color`
/// (value 0).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Texture {
    /// Squares of side `size`: parity of ⌊u/size⌋ + ⌊v/size⌋. Receding to
    /// the horizon, its frequency grows without bound: the classic aliasing
    /// test.
    Checker {
        size: f32,
        color: Color,
        #[serde(default)]
        origin: Vec3,
        #[serde(default = "x_axis")]
        u_axis: Vec3,
        #[serde(default = "z_axis")]
        v_axis: Vec3,
    },
    /// The zone plate ½(1 + sin(k·r²)), r² = u² + v²: its local frequency
    /// k·r/π cycles per unit grows linearly with r, so one image shows every
    /// frequency from 0 to far beyond the pixel rate.
    ZonePlate {
        k: f32,
        color: Color,
        #[serde(default)]
        origin: Vec3,
        #[serde(default = "x_axis")]
        u_axis: Vec3,
        #[serde(default = "z_axis")]
        v_axis: Vec3,
    },
}

fn x_axis() -> Vec3 {
    Vec3::X
}
fn z_axis() -> Vec3 {
    Vec3::Z
}

impl Texture {
    /// The pattern's value in [0, 1] at `p` (1 = the material's colour).
    pub fn value(&self, p: Vec3) -> f32 {
        self.value_at(V3::<f32>::from(p))
    }

    /// [`Texture::value`] over [`Real`]: the zone plate is a smooth function
    /// of the point; the checker is piecewise constant (its derivative is 0
    /// inside a square; its edges are visibility-like discontinuities).
    pub fn value_at<R: Real>(&self, p: V3<R>) -> R {
        match *self {
            Texture::Checker {
                size,
                origin,
                u_axis,
                v_axis,
                ..
            } => {
                let d = p.value() - origin;
                let (u, v) = (d.dot(u_axis) / size, d.dot(v_axis) / size);
                let parity = (u.floor() as i64 + v.floor() as i64).rem_euclid(2);
                R::from_f32(if parity == 0 { 1.0 } else { 0.0 })
            }
            Texture::ZonePlate {
                k,
                origin,
                u_axis,
                v_axis,
                ..
            } => {
                let d = p - V3::from_vec3(origin);
                let (u, v) = (d.dot(V3::from_vec3(u_axis)), d.dot(V3::from_vec3(v_axis)));
                let half = R::from_f32(0.5);
                half * (R::one() + (R::from_f32(k) * (u * u + v * v)).sin())
            }
        }
    }

    /// Check ranges; the message names the field.
    pub fn validate(&self) -> Result<(), RangeError> {
        let (scale_name, scale, color, u, v) = match *self {
            Texture::Checker {
                size,
                color,
                u_axis,
                v_axis,
                ..
            } => ("size", size, color, u_axis, v_axis),
            Texture::ZonePlate {
                k,
                color,
                u_axis,
                v_axis,
                ..
            } => ("k", k, color, u_axis, v_axis),
        };
        if !(scale > 0.0 && scale.is_finite()) {
            return Err(RangeError::new(scale_name, "positive and finite", scale));
        }
        if !(color.is_finite() && color.min_element() >= 0.0) {
            return Err(RangeError::new("color", "non-negative and finite", color));
        }
        for (name, a) in [("u_axis", u), ("v_axis", v)] {
            if !(a.is_finite() && a.length() > 0.0) {
                return Err(RangeError::new(name, "a finite non-zero vector", a));
            }
        }
        Ok(())
    }

    /// The colour where the pattern's value is 0.
    fn other_color(&self) -> Color {
        match *self {
            Texture::Checker { color, .. } | Texture::ZonePlate { color, .. } => color,
        }
    }
}

impl Default for Material {
    fn default() -> Self {
        Self {
            color: Color::splat(0.8),
            ambient: 0.1,
            diffuse: 0.9,
            specular: 0.0,
            shininess: 32.0,
            specular_color: Color::ONE,
            reflectivity: 0.0,
            transparency: 0.0,
            ior: 1.0,
            emission: Color::ZERO,
            texture: None,
        }
    }
}

/// A material's numbers over [`Real`]: what the integrators read at a hit.
/// [`Material::real`] gives the constant one; the derivative code builds
/// ones whose fields carry derivatives with respect to scene parameters.
#[derive(Clone, Copy, Debug)]
pub struct MaterialR<R> {
    pub color: V3<R>,
    pub ambient: R,
    pub diffuse: R,
    pub specular: R,
    pub shininess: R,
    pub specular_color: V3<R>,
    pub reflectivity: R,
    pub transparency: R,
    pub ior: R,
    pub emission: V3<R>,
    pub texture: Option<Texture>,
}

impl<R: Real> MaterialR<R> {
    /// The surface colour at `p`: `color`, or the texture's mix of `color`
    /// and its own colour.
    #[inline]
    pub fn color_at(&self, p: V3<R>) -> V3<R> {
        match &self.texture {
            None => self.color,
            Some(t) => {
                let w = t.value_at(p);
                self.color * w + V3::from_vec3(t.other_color()) * (R::one() - w)
            }
        }
    }

    /// The Lambertian albedo ρ the path tracer uses at `p`: the Phong
    /// diffuse reflectance k_d × colour (textured where the material has a
    /// texture), clamped to [0, 1] per channel so that no surface reflects
    /// more than it receives.
    #[inline]
    pub fn lambert_albedo(&self, p: V3<R>) -> V3<R> {
        (self.color_at(p) * self.diffuse).clamp(0.0, 1.0)
    }
}

impl Material {
    /// The material's numbers as constants over [`Real`].
    #[inline]
    pub fn real<R: Real>(&self) -> MaterialR<R> {
        let c = V3::from_vec3;
        let r = R::from_f32;
        MaterialR {
            color: c(self.color),
            ambient: r(self.ambient),
            diffuse: r(self.diffuse),
            specular: r(self.specular),
            shininess: r(self.shininess),
            specular_color: c(self.specular_color),
            reflectivity: r(self.reflectivity),
            transparency: r(self.transparency),
            ior: r(self.ior),
            emission: c(self.emission),
            texture: self.texture,
        }
    }

    /// The surface colour at `p` ([`MaterialR::color_at`]).
    #[inline]
    pub fn color_at(&self, p: Vec3) -> Color {
        self.real::<f32>().color_at(p.into()).into()
    }

    /// The Lambertian albedo at `p` ([`MaterialR::lambert_albedo`]).
    #[inline]
    pub fn lambert_albedo(&self, p: Vec3) -> Color {
        self.real::<f32>().lambert_albedo(p.into()).into()
    }

    /// Check ranges; returns a message naming the offending field.
    pub fn validate(&self) -> Result<(), RangeError> {
        let unit = |name: &str, v: f32| {
            if (0.0..=1.0).contains(&v) {
                Ok(())
            } else {
                Err(RangeError::new(name, "in [0, 1]", v))
            }
        };
        unit("reflectivity", self.reflectivity)?;
        unit("transparency", self.transparency)?;
        for (name, v) in [
            ("ambient", self.ambient),
            ("diffuse", self.diffuse),
            ("specular", self.specular),
            ("shininess", self.shininess),
        ] {
            if !(v >= 0.0 && v.is_finite()) {
                return Err(RangeError::new(name, "non-negative and finite", v));
            }
        }
        if !(self.ior > 0.0 && self.ior.is_finite()) {
            return Err(RangeError::new("ior", "positive and finite", self.ior));
        }
        for (name, c) in [
            ("color", self.color),
            ("specular_color", self.specular_color),
            ("emission", self.emission),
        ] {
            if !(c.is_finite() && c.min_element() >= 0.0) {
                return Err(RangeError::new(name, "non-negative and finite", c));
            }
        }
        if let Some(t) = &self.texture {
            t.validate().map_err(|e| e.within("texture"))?;
        }
        Ok(())
    }
}
