//! The build settings of an Embree accelerator and their names,
//! `embree[:low|medium|high][+robust]`: Embree's build quality and its
//! robust-traversal flag. Part of [`crate::accel::embree`].

use crate::error::ParseError;
use embree4_sys as sys;
use std::fmt;
use std::str::FromStr;

/// Embree's BVH build quality (`RTC_BUILD_QUALITY_*`): build time against
/// trace time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum BuildQuality {
    /// Fast (Morton-code) build, slower traversal.
    Low,
    /// Embree's default: binned SAH.
    #[default]
    Medium,
    /// SAH with spatial splits: slowest build, fastest traversal.
    High,
}

impl BuildQuality {
    /// The `RTC_BUILD_QUALITY_*` value.
    pub(super) fn to_sys(self) -> sys::RTCBuildQuality {
        match self {
            BuildQuality::Low => sys::RTCBuildQuality::LOW,
            BuildQuality::Medium => sys::RTCBuildQuality::MEDIUM,
            BuildQuality::High => sys::RTCBuildQuality::HIGH,
        }
    }

    fn name(self) -> &'static str {
        match self {
            BuildQuality::Low => "low",
            BuildQuality::Medium => "medium",
            BuildQuality::High => "high",
        }
    }
}

/// How to build the Embree scene. Named `embree[:low|medium|high][+robust]`
/// (see [`EMBREE_GRAMMAR`]); plain `embree` is medium quality, not robust.
///
/// ```
/// use raylab::accel::embree::{BuildQuality, EmbreeConfig};
/// let c: EmbreeConfig = "embree:high+robust".parse().unwrap();
/// assert_eq!((c.quality, c.robust), (BuildQuality::High, true));
/// assert_eq!(EmbreeConfig::default().to_string(), "embree");
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct EmbreeConfig {
    pub quality: BuildQuality,
    /// `RTC_SCENE_FLAG_ROBUST`: robust traversal, no optimisations that
    /// trade arithmetic accuracy for speed; meant against rays slipping
    /// between neighbouring triangles (Embree does not promise a watertight
    /// test even so). About a third slower on the camel.
    pub robust: bool,
}

/// The accepted accelerator names, for error messages.
pub const EMBREE_GRAMMAR: &str = "`embree[:low|medium|high][+robust]`";

impl FromStr for EmbreeConfig {
    type Err = ParseError;
    fn from_str(s: &str) -> Result<Self, ParseError> {
        let bad = || ParseError::Unknown {
            what: "accelerator",
            given: s.to_string(),
            expected: EMBREE_GRAMMAR.into(),
        };
        let rest = s.strip_prefix("embree").ok_or_else(bad)?;
        let (rest, robust) = match rest.strip_suffix("+robust") {
            Some(r) => (r, true),
            None => (rest, false),
        };
        let quality = match rest {
            "" => BuildQuality::Medium,
            ":low" => BuildQuality::Low,
            ":medium" => BuildQuality::Medium,
            ":high" => BuildQuality::High,
            _ => return Err(bad()),
        };
        Ok(Self { quality, robust })
    }
}

impl fmt::Display for EmbreeConfig {
    /// The shortest name that parses back to the same configuration.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "embree")?;
        if self.quality != BuildQuality::Medium {
            write!(f, ":{}", self.quality.name())?;
        }
        if self.robust {
            write!(f, "+robust")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_and_print_back() {
        for (name, quality, robust) in [
            ("embree", BuildQuality::Medium, false),
            ("embree:low", BuildQuality::Low, false),
            ("embree:high", BuildQuality::High, false),
            ("embree+robust", BuildQuality::Medium, true),
            ("embree:high+robust", BuildQuality::High, true),
        ] {
            let c: EmbreeConfig = name.parse().unwrap();
            assert_eq!(c, EmbreeConfig { quality, robust });
            assert_eq!(c.to_string(), name);
        }
        assert_eq!(
            "embree:medium".parse::<EmbreeConfig>().unwrap().to_string(),
            "embree"
        );
        for bad in [
            "embre",
            "embree:",
            "embree:fast",
            "embree+robust:high",
            "embree++robust",
            "bvh",
        ] {
            let e = bad.parse::<EmbreeConfig>().unwrap_err();
            assert!(
                e.to_string().contains(bad) && e.to_string().contains("embree[:low"),
                "{e}"
            );
        }
    }
}
