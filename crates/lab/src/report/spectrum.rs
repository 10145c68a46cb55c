//! The `raylab spectrum` report: the periodograms of sampling patterns,
//! their files (periodogram images, radial and anisotropy charts, the
//! per-ring CSV) and a summary table. Part of the top-layer
//! [`crate::report`]; the spectra themselves are
//! [`crate::analysis::spectrum`].

use crate::analysis::spectrum::{
    check_sets_and_freq, summary_table, write_spectra, PatternSpectrum,
};
use crate::Error;
use raylab::sampler::Sampler;
use std::fmt;
use std::path::PathBuf;

/// What `raylab spectrum` was asked to do.
#[derive(Clone, Debug, PartialEq)]
pub struct SpectrumOptions {
    /// The samplers, each one pattern.
    pub samplers: Vec<Sampler>,
    /// Point sets (pixels) averaged, M.
    pub sets: usize,
    /// Frequency bound F: k ranges over [−F, F]².
    pub freq: usize,
    /// Seed of the randomised samplers.
    pub seed: u64,
    /// Output folder (created if missing).
    pub out: PathBuf,
}

/// The spectra computed and the files written.
#[derive(Clone, Debug, PartialEq)]
pub struct SpectrumReport {
    /// One spectrum per sampler, in the order given.
    pub spectra: Vec<PatternSpectrum>,
    /// The files written, relative to `out`.
    pub written: Vec<String>,
    /// The output folder.
    pub out: PathBuf,
}

impl SpectrumReport {
    /// Check the options, compute every sampler's periodogram and write
    /// the files.
    pub fn run(opts: &SpectrumOptions) -> Result<Self, Error> {
        for s in &opts.samplers {
            check_sets_and_freq(opts.sets, opts.freq, s.spp())?;
        }
        let spectra: Vec<_> = opts
            .samplers
            .iter()
            .map(|s| PatternSpectrum::compute(s.name(), *s, opts.sets, opts.freq, opts.seed))
            .collect();
        let written = write_spectra(&opts.out, &spectra)?;
        Ok(Self {
            spectra,
            written,
            out: opts.out.clone(),
        })
    }
}

impl fmt::Display for SpectrumReport {
    /// The summary table, then the files written.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&summary_table(&self.spectra))?;
        writeln!(
            f,
            "wrote {} in {}",
            self.written.join(", "),
            self.out.display()
        )
    }
}
