//! `data.csv`, the table of an experiment: one header line, then one row per
//! finished run, appended and flushed as each run ends so that an
//! interrupted sweep keeps what it finished.
//!
//! A process killed in the middle of writing a row leaves a last line
//! without its newline; [`Table::read`] drops such a line (and says so), so
//! `--resume` simply runs that point again.

use anyhow::{bail, Context};
use std::fs::{File, OpenOptions};
use std::path::{Path, PathBuf};

/// The file name of the table inside an experiment's output folder.
pub const DATA_FILE: &str = "data.csv";

/// A CSV table held as text: what the figures and `--resume` read.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Table {
    /// Column names, from the header line.
    pub columns: Vec<String>,
    /// Rows, each with exactly one cell per column.
    pub rows: Vec<Vec<String>>,
}

impl Table {
    /// Read a CSV file. Returns the table and whether an incomplete last
    /// line (no final newline: a write that was cut short) was dropped.
    /// Rows with the wrong number of cells are errors naming the line.
    pub fn read(path: &Path) -> anyhow::Result<(Table, bool)> {
        let mut text = std::fs::read_to_string(path)
            .with_context(|| format!("{}: cannot read", path.display()))?;
        let mut dropped = false;
        if !text.is_empty() && !text.ends_with('\n') {
            let keep = text.rfind('\n').map_or(0, |i| i + 1);
            text.truncate(keep);
            dropped = true;
        }
        if text.is_empty() {
            bail!("{}: no header line", path.display());
        }
        let mut reader = csv::ReaderBuilder::new()
            .flexible(true)
            .from_reader(text.as_bytes());
        let columns: Vec<String> = reader
            .headers()
            .with_context(|| format!("{}:1: cannot read the header", path.display()))?
            .iter()
            .map(str::to_string)
            .collect();
        let mut rows = Vec::new();
        for record in reader.records() {
            let record = record.with_context(|| format!("{}: cannot read", path.display()))?;
            if record.len() != columns.len() {
                let line = record.position().map_or(0, |p| p.line());
                bail!(
                    "{}:{line}: row has {} cells, the header has {}",
                    path.display(),
                    record.len(),
                    columns.len()
                );
            }
            rows.push(record.iter().map(str::to_string).collect());
        }
        Ok((Table { columns, rows }, dropped))
    }

    /// The index of column `name`.
    pub fn column(&self, name: &str) -> Option<usize> {
        self.columns.iter().position(|c| c == name)
    }
}

/// Appends rows to `data.csv`, flushing after each.
pub struct RowWriter {
    path: PathBuf,
    writer: csv::Writer<File>,
    width: usize,
}

impl RowWriter {
    /// Start `path` afresh with a header line only. The header is written
    /// to a temporary file and renamed over any old table, so the old table
    /// is replaced whole or not at all.
    pub fn create(path: &Path, columns: &[String]) -> anyhow::Result<RowWriter> {
        Self::start(path, columns, &[])
    }

    /// Continue `path` from `table`: its rows are kept (the file is
    /// rewritten atomically, which also removes an incomplete last line)
    /// and new rows are appended after them.
    pub fn resume(path: &Path, table: &Table) -> anyhow::Result<RowWriter> {
        Self::start(path, &table.columns, &table.rows)
    }

    fn start(path: &Path, columns: &[String], rows: &[Vec<String>]) -> anyhow::Result<RowWriter> {
        raylab::io::write_atomically(path, |tmp| {
            let mut w = csv::Writer::from_path(tmp)
                .with_context(|| format!("{}: cannot create", path.display()))?;
            w.write_record(columns)?;
            for row in rows {
                w.write_record(row)?;
            }
            w.flush()
                .with_context(|| format!("{}: cannot write", path.display()))
        })?;
        let file = OpenOptions::new()
            .append(true)
            .open(path)
            .with_context(|| format!("{}: cannot open for appending", path.display()))?;
        Ok(RowWriter {
            path: path.to_path_buf(),
            writer: csv::WriterBuilder::new()
                .has_headers(false)
                .from_writer(file),
            width: columns.len(),
        })
    }

    /// Append one row and flush it to the file.
    pub fn append(&mut self, row: &[String]) -> anyhow::Result<()> {
        anyhow::ensure!(
            row.len() == self.width,
            "{}: a row of {} cells for {} columns",
            self.path.display(),
            row.len(),
            self.width
        );
        self.writer
            .write_record(row)
            .and_then(|()| self.writer.flush().map_err(csv::Error::from))
            .with_context(|| format!("{}: cannot append a row", self.path.display()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cut_last_line_is_dropped_and_quoting_round_trips() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.csv");
        let cols = vec!["a".to_string(), "b".to_string()];
        let mut w = RowWriter::create(&path, &cols).unwrap();
        w.append(&["x,1".into(), "2".into()]).unwrap();
        w.append(&["y".into(), "3".into()]).unwrap();
        drop(w);
        let (t, dropped) = Table::read(&path).unwrap();
        assert!(!dropped);
        assert_eq!(t.rows, vec![vec!["x,1", "2"], vec!["y", "3"]]);
        let text = std::fs::read_to_string(&path).unwrap();
        std::fs::write(&path, &text[..text.len() - 2]).unwrap();
        let (t, dropped) = Table::read(&path).unwrap();
        assert!(dropped);
        assert_eq!(t.rows.len(), 1);
    }
}
