//! Lights. Point lights as in S1/S2: a position, a colour and an intensity;
//! shadows are hard (one shadow ray per light).

use crate::math::{Color, Vec3};

/// How a point light's irradiance falls off with distance d.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Falloff {
    /// No falloff: the sources' classroom model (S1/S2).
    #[default]
    None,
    /// Physical 1/d².
    InverseSquare,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointLight {
    pub position: Vec3,
    /// Colour × intensity.
    pub radiance: Color,
    pub falloff: Falloff,
}

impl PointLight {
    /// The light's contribution arriving at distance `d`.
    #[inline]
    pub fn arriving(&self, d: f32) -> Color {
        match self.falloff {
            Falloff::None => self.radiance,
            Falloff::InverseSquare => self.radiance / (d * d),
        }
    }
}
