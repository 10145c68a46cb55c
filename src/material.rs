//! Materials of S1/S2: the Phong local model (ambient, diffuse, specular)
//! plus Whitted's reflectivity and transparency with an index of refraction.
//!
//! The specular term is Phong's, (R·V)^shininess with R the light direction
//! mirrored about the normal (not Blinn–Phong's half vector), as in the
//! sources.

use crate::math::Color;
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
        }
    }
}

impl Material {
    /// The Lambertian albedo ρ the path tracer uses: the Phong diffuse
    /// reflectance k_d × colour, clamped to [0, 1] per channel so that no
    /// surface reflects more than it receives.
    #[inline]
    pub fn lambert_albedo(&self) -> Color {
        (self.diffuse * self.color).clamp(Color::ZERO, Color::ONE)
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
        Ok(())
    }
}
