//! The `raylab diff` report: an image against a reference (MSE, relMSE,
//! PSNR, largest error, ꟻLIP), with the ꟻLIP error map written on request,
//! displayed as a table or as one JSON object. Part of the top-layer
//! [`crate::report`]; the metrics themselves are [`crate::analysis::metrics`].

use crate::analysis::{diff_files, ImageMetrics};
use crate::Error;
use std::fmt;
use std::path::{Path, PathBuf};

/// The metrics of one `raylab diff`, with the files they came from.
#[derive(Clone, Debug, PartialEq)]
pub struct DiffReport {
    /// The image judged.
    pub test: PathBuf,
    /// The reference image.
    pub reference: PathBuf,
    /// Where the ꟻLIP error map was written, if asked for.
    pub error_map: Option<PathBuf>,
    /// The metrics.
    pub metrics: ImageMetrics,
}

impl DiffReport {
    /// Read both images, compute the metrics and write the ꟻLIP error map
    /// to `error_map` when given.
    pub fn run(test: &Path, reference: &Path, error_map: Option<&Path>) -> Result<Self, Error> {
        let metrics = diff_files(test, reference, error_map)?;
        Ok(Self {
            test: test.to_path_buf(),
            reference: reference.to_path_buf(),
            error_map: error_map.map(Path::to_path_buf),
            metrics,
        })
    }

    /// The report as one pretty-printed JSON object and a line end: the
    /// metrics, `test`, `reference` and (when written) `error_map`. JSON
    /// has no infinity (serde_json would write null), so identical images
    /// get the PSNR `"inf"`, as Python's `float("inf")` reads it.
    pub fn json(&self) -> Result<String, Error> {
        let json_error = |error| Error::Json {
            what: "the diff report",
            error,
        };
        let mut json = serde_json::to_value(self.metrics).map_err(json_error)?;
        if self.metrics.psnr.is_infinite() {
            json["psnr"] = serde_json::Value::from("inf");
        }
        json["test"] = self.test.display().to_string().into();
        json["reference"] = self.reference.display().to_string().into();
        if let Some(out) = &self.error_map {
            json["error_map"] = out.display().to_string().into();
        }
        Ok(format!(
            "{}\n",
            serde_json::to_string_pretty(&json).map_err(json_error)?
        ))
    }
}

impl fmt::Display for DiffReport {
    /// The table: both files, the metrics, and the error map written.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "test       {}", self.test.display())?;
        writeln!(f, "reference  {}", self.reference.display())?;
        write!(f, "{}", self.metrics)?;
        if let Some(out) = &self.error_map {
            writeln!(f, "wrote      {}", out.display())?;
        }
        Ok(())
    }
}
