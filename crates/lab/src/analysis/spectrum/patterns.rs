//! Sampling-pattern reports, as `raylab spectrum` and the `aa_patterns`
//! study make them: the checked inputs, each sampler's periodogram with its
//! summary, the files written for them and a plain-text table. Part of
//! [`crate::analysis::spectrum`].

use super::curves::{
    anisotropy_chart, periodogram_heatmap, radial_chart, write_rings_csv, RadialCurve,
};
use super::periodogram::{sampler_periodogram, Periodogram, SpectrumSummary, MAX_FREQ};
use crate::analysis::plot::PlotError;
use crate::{Error, FileOp};
use raylab::sampler::Sampler;
use std::path::Path;

/// The largest number of sets accepted (a typo guard: 10⁶ sets of 64
/// points at F = 32 is already minutes of work).
pub const MAX_SETS: usize = 1_000_000;

/// The most terms exp(−2πi k·x) one periodogram may sum, sets × points ×
/// (2F+1)²: 2⁴⁰ ≈ 1.1·10¹², about 40 minutes on two cores at the
/// 2.3·10⁸ terms a second one core of the project's machine sums (16384
/// sets of 64 points at F = 32 in 19 s); the largest study, 1024 sets of
/// 64 points at F = 32, sums 2.8·10⁸. Each bound
/// alone allows far more (10⁶ sets of 65536 points at F = 512 would take
/// years), so the product is checked too.
pub const MAX_TERMS: u128 = 1 << 40;

/// Check a set count, a frequency bound and the work they make with `spp`
/// points per set: an [`Error::Argument`] saying what is expected.
pub fn check_sets_and_freq(sets: usize, freq: usize, spp: u32) -> Result<(), Error> {
    if !(1..=MAX_SETS).contains(&sets) {
        return Err(Error::Argument(format!(
            "the number of point sets must be in 1..={MAX_SETS}, got {sets}"
        )));
    }
    if !(2..=MAX_FREQ).contains(&freq) {
        return Err(Error::Argument(format!(
            "the frequency bound F must be in 2..={MAX_FREQ} (rings 1 … F−1 are reported), got {freq}"
        )));
    }
    let side = 2 * freq as u128 + 1;
    let terms = sets as u128 * u128::from(spp) * side * side;
    if terms > MAX_TERMS {
        return Err(Error::Argument(format!(
            "{sets} sets of {spp} points at F = {freq} sum {terms:.2e} terms, more than \
             2^40 ≈ 1.1e12 (about 40 minutes on two cores): use fewer sets, fewer samples \
             or a lower F",
            terms = terms as f64
        )));
    }
    Ok(())
}

/// One sampling pattern's spectrum, labelled.
#[derive(Clone, Debug, PartialEq)]
pub struct PatternSpectrum {
    /// How the user named the sampler (`jitter:4`).
    pub label: String,
    /// The sampler.
    pub sampler: Sampler,
    /// Its periodogram.
    pub periodogram: Periodogram,
    /// Its summary numbers.
    pub summary: SpectrumSummary,
}

impl PatternSpectrum {
    /// Compute the periodogram of `sampler` over `sets` pixels.
    pub fn compute(
        label: impl Into<String>,
        sampler: Sampler,
        sets: usize,
        freq: usize,
        seed: u64,
    ) -> Self {
        let periodogram = sampler_periodogram(&sampler, sets, freq, seed);
        let summary = periodogram.summary();
        Self {
            label: label.into(),
            sampler,
            periodogram,
            summary,
        }
    }

    /// Its rings as a curve.
    pub fn curve(&self) -> RadialCurve {
        RadialCurve::new(self.label.clone(), &self.periodogram)
    }

    /// Write its periodogram image as `stem.png` and `stem.svg`.
    pub fn save_heatmap(&self, stem: &Path) -> Result<(), PlotError> {
        let p = &self.periodogram;
        periodogram_heatmap(
            p,
            format!(
                "Periodogram of {} (N = {}, mean of M = {} sets)",
                self.label, p.points, p.sets
            ),
        )
        .save(stem)
    }
}

/// Write the files of `raylab spectrum` into `out` (created if missing):
/// the periodogram image `spectrum.png`/`.svg` (one sampler) or
/// `spectrum-NAME.png`/`.svg` (several), the overlaid `radial` and
/// `anisotropy` charts (PNG + SVG) and `spectrum.csv` (every ring of every
/// sampler). Returns the paths written.
pub fn write_spectra(out: &Path, spectra: &[PatternSpectrum]) -> Result<Vec<String>, Error> {
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, FileOp::CreateOutputFolder, e))?;
    let mut written = Vec::new();
    for s in spectra {
        let stem = if spectra.len() == 1 {
            "spectrum".to_string()
        } else {
            format!("spectrum-{}", s.sampler.name())
        };
        s.save_heatmap(&out.join(&stem))?;
        written.push(format!("{stem}.png"));
    }
    let curves: Vec<RadialCurve> = spectra.iter().map(PatternSpectrum::curve).collect();
    radial_chart(&curves, "Radially averaged power of the sampling patterns")
        .save(&out.join("radial"))?;
    anisotropy_chart(&curves, "Anisotropy of the sampling patterns")
        .save(&out.join("anisotropy"))?;
    write_rings_csv(&out.join("spectrum.csv"), &curves)?;
    written.extend([
        "radial.png".into(),
        "anisotropy.png".into(),
        "spectrum.csv".into(),
    ]);
    Ok(written)
}

/// A plain-text table of the summaries, one line per sampler.
pub fn summary_table(spectra: &[PatternSpectrum]) -> String {
    use std::fmt::Write as _;
    let mut t = String::new();
    let _ = writeln!(
        t,
        "{:<12} {:>5} {:>7} {:>12} {:>12} {:>11} {:>13} {:>15}",
        "sampler",
        "N",
        "sets",
        "P(|k|≤√N/2)",
        "mean radial",
        "peak P",
        "at k (|k|)",
        "anisotropy dB"
    );
    for s in spectra {
        let m = &s.summary;
        let _ = writeln!(
            t,
            "{:<12} {:>5} {:>7} {:>12.4} {:>12.4} {:>11.4} {:>13} {:>15.2}",
            s.label,
            s.periodogram.points,
            s.periodogram.sets,
            m.low_freq_power,
            m.mean_radial_power,
            m.peak_power,
            format!("({},{}) {:.2}", m.peak_k.0, m.peak_k.1, m.peak_radius()),
            m.mean_anisotropy_db,
        );
    }
    if let Some(s) = spectra.first() {
        let _ = writeln!(
            t,
            "white noise: P = 1 at every k ≠ 0; anisotropy 10·log10(1/M) = {:.2} dB for M = {}",
            s.summary.white_noise_anisotropy_db, s.periodogram.sets
        );
    }
    t
}
