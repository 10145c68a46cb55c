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

use crate::math::{Color, Vec3};
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
        match *self {
            Texture::Checker {
                size,
                origin,
                u_axis,
                v_axis,
                ..
            } => {
                let d = p - origin;
                let (u, v) = (d.dot(u_axis) / size, d.dot(v_axis) / size);
                let parity = (u.floor() as i64 + v.floor() as i64).rem_euclid(2);
                if parity == 0 {
                    1.0
                } else {
                    0.0
                }
            }
            Texture::ZonePlate {
                k,
                origin,
                u_axis,
                v_axis,
                ..
            } => {
                let d = p - origin;
                let (u, v) = (d.dot(u_axis), d.dot(v_axis));
                0.5 * (1.0 + (k * (u * u + v * v)).sin())
            }
        }
    }

    /// Check ranges; the message names the field.
    pub fn validate(&self) -> Result<(), String> {
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
            return Err(format!(
                "`{scale_name}` must be positive and finite, got {scale}"
            ));
        }
        if !(color.is_finite() && color.min_element() >= 0.0) {
            return Err(format!(
                "`color` must be non-negative and finite, got {color}"
            ));
        }
        for (name, a) in [("u_axis", u), ("v_axis", v)] {
            if !(a.is_finite() && a.length() > 0.0) {
                return Err(format!(
                    "`{name}` must be a finite non-zero vector, got {a}"
                ));
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

impl Material {
    /// The surface colour at `p`: `color`, or the texture's mix of `color`
    /// and its own colour.
    #[inline]
    pub fn color_at(&self, p: Vec3) -> Color {
        match &self.texture {
            None => self.color,
            Some(t) => {
                let w = t.value(p);
                w * self.color + (1.0 - w) * t.other_color()
            }
        }
    }

    /// The Lambertian albedo ρ the path tracer uses at `p`: the Phong
    /// diffuse reflectance k_d × colour (textured where the material has a
    /// texture), clamped to [0, 1] per channel so that no surface reflects
    /// more than it receives.
    #[inline]
    pub fn lambert_albedo(&self, p: Vec3) -> Color {
        (self.diffuse * self.color_at(p)).clamp(Color::ZERO, Color::ONE)
    }

    /// Check ranges; returns a message naming the offending field.
    pub fn validate(&self) -> Result<(), String> {
        let unit = |name: &str, v: f32| {
            if (0.0..=1.0).contains(&v) {
                Ok(())
            } else {
                Err(format!("`{name}` must be in [0, 1], got {v}"))
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
                return Err(format!("`{name}` must be non-negative and finite, got {v}"));
            }
        }
        if !(self.ior > 0.0 && self.ior.is_finite()) {
            return Err(format!(
                "`ior` must be positive and finite, got {}",
                self.ior
            ));
        }
        for (name, c) in [
            ("color", self.color),
            ("specular_color", self.specular_color),
            ("emission", self.emission),
        ] {
            if !(c.is_finite() && c.min_element() >= 0.0) {
                return Err(format!("`{name}` must be non-negative and finite, got {c}"));
            }
        }
        if let Some(t) = &self.texture {
            t.validate().map_err(|e| format!("`texture`: {e}"))?;
        }
        Ok(())
    }
}
