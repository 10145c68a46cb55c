//! `kind = "aa_patterns"`: the spectra of anti-aliasing sampling patterns
//! (ordered and rotated grids, jitter, random, Halton, Sobol), as point-set
//! periodograms after Heck, Schlömer and Deussen 2013
//! ([`crate::analysis::spectrum`]).
//!
//! One run computes the periodogram of one sampler, averaged over `sets`
//! pixels, and writes per-run files into the output folder:
//! `aa-NAME-spectrum.png`/`.svg` (the periodogram image) and
//! `aa-NAME-radial.csv` (every ring: mean power, variance, anisotropy),
//! where NAME is the sampler's short name followed by the set count,
//! frequency bound and seed. Its row of `data.csv` holds the summary
//! numbers and the two file names.
//!
//! The classic overlaid radial curves need every ring of every sampler,
//! which a row of `data.csv` cannot hold, so the study draws them itself
//! ([`Study::figures`]): after the sweep it reads the rows' radial CSVs
//! (named in `data.csv`, so `--resume` redraws from all runs and stale
//! files of other experiments are never picked up) and draws
//! `aa-radial-Nspp` and `aa-anisotropy-Nspp` for each sample count N.
//! Summary columns go through the manifest's ordinary `[[figure]]`s.

use super::{RunContext, Study};
use crate::analysis::spectrum::{
    anisotropy_chart, check_sets_and_freq, radial_chart, read_rings_csv, write_rings_csv,
    PatternSpectrum, RadialCurve, MAX_FREQ, MAX_SETS,
};
use crate::experiment::data::Table;
use crate::experiment::params::{parsed, typed_params, InRange, ParamDoc, RunParamError};
use crate::experiment::row::{Fixed, Sci, Secs};
use crate::experiment::sweep::RunPoint;
use crate::Error;
use raylab::io::InputError;
use raylab::sampler::Sampler;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

/// The `aa_patterns` study.
#[derive(Clone, Copy, Debug, Default)]
pub struct AaPatterns;

/// The parameters of a run.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AaPatternsParams {
    /// The sampling pattern.
    #[serde(deserialize_with = "parsed")]
    pub sampler: Sampler,
    /// Point sets (pixels) averaged.
    #[serde(default)]
    pub sets: Option<InRange<1, { MAX_SETS as i64 }>>,
    /// Frequency bound.
    #[serde(default)]
    pub freq: Option<InRange<2, { MAX_FREQ as i64 }>>,
    /// Seed of the randomised samplers.
    #[serde(default)]
    pub seed: Option<u64>,
}

typed_params!(
    AaPatternsParams,
    [
        ParamDoc {
            name: "sampler",
            doc: "the sampling pattern, as `raylab render --sampler` (`ogss:4`, `rgss`, \
                  `jitter:4`, `random:16`, `halton:16`, `sobol:16`, …); required",
        },
        ParamDoc {
            name: "sets",
            doc: "point sets (pixels) averaged, M (default 1024)",
        },
        ParamDoc {
            name: "freq",
            doc: "frequency bound F: k in [−F, F]², rings 1 … F−1 (default 32)",
        },
        ParamDoc {
            name: "seed",
            doc: "seed of the randomised samplers (default 1)",
        },
    ]
);

/// Defaults of the parameters (as `raylab spectrum`).
const DEFAULT_SETS: usize = 1024;
const DEFAULT_FREQ: usize = 32;
const DEFAULT_SEED: u64 = 1;

/// A run's parameters, checked.
pub struct AaPatternsConfig {
    sampler: Sampler,
    sets: usize,
    freq: usize,
    seed: u64,
}

impl AaPatternsConfig {
    /// The stem of this run's files.
    fn stem(&self) -> String {
        format!(
            "aa-{}-m{}-f{}-s{}",
            self.sampler.name(),
            self.sets,
            self.freq,
            self.seed
        )
    }
}

/// One row: the summary of one sampler's periodogram, and its files.
#[derive(Clone, Debug, Default, Serialize)]
pub struct AaPatternsRow {
    /// Samples per pixel.
    pub spp: u32,
    /// Rings of the radial profile.
    pub rings: usize,
    /// Mean power for 0 < |k| ≤ √N/2.
    pub low_freq_power: Sci<6>,
    /// Mean of the radial profile.
    pub mean_radial_power: Sci<6>,
    /// Largest power over k ≠ 0.
    pub peak_power: Sci<6>,
    /// Its frequency, x.
    pub peak_kx: i64,
    /// Its frequency, y.
    pub peak_ky: i64,
    /// |k| of the peak.
    pub peak_radius: Fixed<6>,
    /// Mean anisotropy over the rings, dB.
    pub mean_anisotropy_db: Fixed<4>,
    /// Anisotropy of white noise with as many sets, dB.
    pub white_noise_anisotropy_db: Fixed<4>,
    /// Time to compute the periodogram.
    pub compute_s: Secs,
    /// The periodogram image.
    pub spectrum_png: String,
    /// Every ring, as CSV.
    pub radial_csv: String,
}

impl Study for AaPatterns {
    type Params = AaPatternsParams;
    type Config = AaPatternsConfig;
    type Row = AaPatternsRow;

    fn configure(
        &self,
        p: AaPatternsParams,
        _base_dir: &Path,
    ) -> Result<AaPatternsConfig, RunParamError> {
        let sets = p.sets.map_or(DEFAULT_SETS, |v| v.get() as usize);
        let freq = p.freq.map_or(DEFAULT_FREQ, |v| v.get() as usize);
        check_sets_and_freq(sets, freq, p.sampler.spp())
            .map_err(|e| RunParamError::new("sets", e.to_string()))?;
        Ok(AaPatternsConfig {
            sampler: p.sampler,
            sets,
            freq,
            seed: p.seed.unwrap_or(DEFAULT_SEED),
        })
    }

    fn run(
        &self,
        cfg: AaPatternsConfig,
        run: &RunPoint,
        ctx: &RunContext<'_>,
    ) -> Result<AaPatternsRow, Error> {
        // The label as the manifest writes it (legends of the overlays).
        let label = run
            .get("sampler")
            .map_or_else(|| cfg.sampler.name(), |v| v.to_string());
        let start = Instant::now();
        let spectrum = PatternSpectrum::compute(&label, cfg.sampler, cfg.sets, cfg.freq, cfg.seed);
        let compute_s = start.elapsed().as_secs_f64();
        let stem = cfg.stem();
        spectrum.save_heatmap(&ctx.out_dir.join(format!("{stem}-spectrum")))?;
        let csv_name = format!("{stem}-radial.csv");
        write_rings_csv(&ctx.out_dir.join(&csv_name), &[spectrum.curve()])?;

        let m = &spectrum.summary;
        Ok(AaPatternsRow {
            spp: cfg.sampler.spp(),
            rings: spectrum.periodogram.rings().len(),
            low_freq_power: Sci(m.low_freq_power),
            mean_radial_power: Sci(m.mean_radial_power),
            peak_power: Sci(m.peak_power),
            peak_kx: m.peak_k.0,
            peak_ky: m.peak_k.1,
            peak_radius: Fixed(m.peak_radius()),
            mean_anisotropy_db: Fixed(m.mean_anisotropy_db),
            white_noise_anisotropy_db: Fixed(m.white_noise_anisotropy_db),
            compute_s: Secs(compute_s),
            spectrum_png: format!("{stem}-spectrum.png"),
            radial_csv: csv_name,
        })
    }

    fn figures(&self, table: &Table, out_dir: &Path) -> Result<Vec<String>, Error> {
        let col = |name: &str| {
            table.column(name).ok_or_else(|| Error::MissingColumn {
                column: name.to_string(),
            })
        };
        let (spp_col, csv_col) = (col("spp")?, col("radial_csv")?);
        // Curves grouped by sample count, in the order of the rows; one
        // file is read once even when several rows name it.
        let mut groups: BTreeMap<usize, Vec<RadialCurve>> = BTreeMap::new();
        let mut seen = Vec::new();
        for row in &table.rows {
            let file = &row[csv_col];
            if seen.contains(file) {
                continue;
            }
            seen.push(file.clone());
            let spp: usize = row[spp_col].parse().map_err(|e| {
                InputError::file(
                    "data.csv",
                    format!("spp `{}` is not a count: {e}", row[spp_col]),
                )
            })?;
            let curves = read_rings_csv(&out_dir.join(file))?;
            groups.entry(spp).or_default().extend(curves);
        }
        let mut written = Vec::new();
        for (spp, curves) in &groups {
            let radial = format!("aa-radial-{spp}spp");
            radial_chart(
                curves,
                format!("Radially averaged power, {spp} samples per pixel"),
            )
            .save(&out_dir.join(&radial))?;
            let aniso = format!("aa-anisotropy-{spp}spp");
            anisotropy_chart(curves, format!("Anisotropy, {spp} samples per pixel"))
                .save(&out_dir.join(&aniso))?;
            written.extend([radial, aniso]);
        }
        Ok(written)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiment::params::Params;
    use crate::experiment::sweep::{RunParam, Value};

    fn point(params: &[(&str, Value)]) -> RunPoint {
        RunPoint {
            sweep: "test".into(),
            params: params
                .iter()
                .map(|(k, v)| RunParam {
                    name: k.to_string(),
                    value: v.clone(),
                    span: 0..0,
                })
                .collect(),
        }
    }

    fn config(run: &RunPoint) -> Result<AaPatternsConfig, RunParamError> {
        AaPatterns.configure(AaPatternsParams::from_run(run)?, Path::new("."))
    }

    #[test]
    fn parameters_are_checked() {
        let ok = point(&[("sampler", Value::Str("jitter:4".into()))]);
        let cfg = config(&ok).unwrap();
        assert_eq!((cfg.sets, cfg.freq, cfg.seed), (1024, 32, 1));
        assert_eq!(cfg.stem(), "aa-jitter4-m1024-f32-s1");
        for (bad, param) in [
            (vec![], None),
            (
                vec![("sampler", Value::Str("poisson:4".into()))],
                Some("sampler"),
            ),
            (
                vec![
                    ("sampler", Value::Str("rgss".into())),
                    ("freq", Value::Int(1)),
                ],
                Some("freq"),
            ),
            (
                vec![
                    ("sampler", Value::Str("rgss".into())),
                    ("sets", Value::Int(0)),
                ],
                Some("sets"),
            ),
        ] {
            let err = config(&point(&bad)).err().expect("an error");
            assert_eq!(err.param.as_deref(), param, "{}", err.message);
        }
    }
}
