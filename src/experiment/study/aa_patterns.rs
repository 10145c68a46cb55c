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

use super::{
    int_param, seconds_cell, str_param, ParamDoc, ParamError, Row, RunContext, Study, StudySettings,
};
use crate::analysis::spectrum::{
    anisotropy_chart, check_sets_and_freq, radial_chart, read_rings_csv, write_rings_csv,
    PatternSpectrum, RadialCurve, MAX_FREQ, MAX_SETS,
};
use crate::experiment::data::Table;
use crate::experiment::sweep::RunPoint;
use crate::sampler::Sampler;
use anyhow::{anyhow, Context};
use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

/// The `aa_patterns` study.
#[derive(Clone, Copy, Debug, Default)]
pub struct AaPatterns;

const PARAMETERS: &[ParamDoc] = &[
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
];

/// Defaults of the parameters (as `raylab spectrum`).
const DEFAULT_SETS: usize = 1024;
const DEFAULT_FREQ: usize = 32;
const DEFAULT_SEED: u64 = 1;

/// A run's parameters, parsed.
struct Config {
    label: String,
    sampler: Sampler,
    sets: usize,
    freq: usize,
    seed: u64,
}

fn config(run: &RunPoint) -> Result<Config, ParamError> {
    let label = str_param(run, "sampler")?.ok_or_else(|| ParamError {
        param: None,
        message: "`sampler` is required (in [fixed] or in the sweep)".into(),
    })?;
    let sampler = Sampler::parse(label).map_err(|e| ParamError::new("sampler", e))?;
    let sets = int_param(run, "sets", 1, MAX_SETS as i64)?.map_or(DEFAULT_SETS, |v| v as usize);
    let freq = int_param(run, "freq", 2, MAX_FREQ as i64)?.map_or(DEFAULT_FREQ, |v| v as usize);
    let seed = int_param(run, "seed", 0, i64::MAX)?.map_or(DEFAULT_SEED, |v| v as u64);
    check_sets_and_freq(sets, freq).map_err(|e| ParamError::new("sets", e))?;
    Ok(Config {
        label: label.to_string(),
        sampler,
        sets,
        freq,
        seed,
    })
}

impl Config {
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

/// The columns of a row, in order.
const COLUMNS: &[&str] = &[
    "spp",
    "rings",
    "low_freq_power",
    "mean_radial_power",
    "peak_power",
    "peak_kx",
    "peak_ky",
    "peak_radius",
    "mean_anisotropy_db",
    "white_noise_anisotropy_db",
    "compute_s",
    "spectrum_png",
    "radial_csv",
];

impl Study for AaPatterns {
    fn kind(&self) -> &'static str {
        "aa_patterns"
    }

    fn parameters(&self) -> &'static [ParamDoc] {
        PARAMETERS
    }

    fn columns(&self, _settings: &StudySettings) -> Vec<String> {
        COLUMNS.iter().map(|s| s.to_string()).collect()
    }

    fn check(&self, run: &RunPoint, _base_dir: &Path) -> Result<(), ParamError> {
        config(run).map(|_| ())
    }

    fn run(&self, run: &RunPoint, ctx: &RunContext<'_>) -> anyhow::Result<Row> {
        let cfg = config(run).map_err(ParamError::into_error)?;
        let start = Instant::now();
        let spectrum =
            PatternSpectrum::compute(&cfg.label, cfg.sampler, cfg.sets, cfg.freq, cfg.seed);
        let compute_s = start.elapsed().as_secs_f64();
        let stem = cfg.stem();
        spectrum.save_heatmap(&ctx.out_dir.join(format!("{stem}-spectrum")))?;
        let csv_name = format!("{stem}-radial.csv");
        write_rings_csv(&ctx.out_dir.join(&csv_name), &[spectrum.curve()])?;

        let m = &spectrum.summary;
        let num = |v: f64| format!("{v:.6e}");
        Ok(vec![
            ("spp".into(), cfg.sampler.spp().to_string()),
            (
                "rings".into(),
                spectrum.periodogram.rings().len().to_string(),
            ),
            ("low_freq_power".into(), num(m.low_freq_power)),
            ("mean_radial_power".into(), num(m.mean_radial_power)),
            ("peak_power".into(), num(m.peak_power)),
            ("peak_kx".into(), m.peak_k.0.to_string()),
            ("peak_ky".into(), m.peak_k.1.to_string()),
            ("peak_radius".into(), format!("{:.6}", m.peak_radius())),
            (
                "mean_anisotropy_db".into(),
                format!("{:.4}", m.mean_anisotropy_db),
            ),
            (
                "white_noise_anisotropy_db".into(),
                format!("{:.4}", m.white_noise_anisotropy_db),
            ),
            ("compute_s".into(), seconds_cell(compute_s)),
            ("spectrum_png".into(), format!("{stem}-spectrum.png")),
            ("radial_csv".into(), csv_name),
        ])
    }

    fn figures(&self, table: &Table, out_dir: &Path) -> anyhow::Result<Vec<String>> {
        let col = |name: &str| {
            table
                .column(name)
                .ok_or_else(|| anyhow!("data.csv has no column `{name}`"))
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
            let spp: usize = row[spp_col]
                .parse()
                .with_context(|| format!("data.csv: spp `{}` is not a count", row[spp_col]))?;
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
