//! `data.csv`, the table of an experiment: one header line, then one row per
//! finished run, appended and flushed as each run ends so that an
//! interrupted sweep keeps what it finished.
//!
//! A process killed in the middle of writing a row leaves a last line
//! without its newline; [`Table::read`] drops such a line (and says so), so
//! `--resume` simply runs that point again.

use crate::{Error, FileOp};
use raylab::io::{InputError, Place};
use std::fs::{File, OpenOptions};
use std::path::{Path, PathBuf};

/// The file name of the table inside an experiment's output folder.
pub const DATA_FILE: &str = "data.csv";

/// A table as [`Table::read`] read it, and whether an incomplete last line
/// (no final newline: a write that was cut short) was dropped.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ReadTable {
    /// The table, without the incomplete line.
    pub table: Table,
    /// Whether an incomplete last line was dropped.
    pub dropped_last_line: bool,
}

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
    pub fn read(path: &Path) -> Result<ReadTable, Error> {
        let mut text =
            raylab::io::input::read_to_string(path, raylab::io::input::InputKind::Table)?;
        let mut dropped = false;
        if !text.is_empty() && !text.ends_with('\n') {
            let keep = text.rfind('\n').map_or(0, |i| i + 1);
            text.truncate(keep);
            dropped = true;
        }
        if text.is_empty() {
            return Err(InputError::file(path, "no header line").into());
        }
        let mut reader = csv::ReaderBuilder::new()
            .flexible(true)
            .from_reader(text.as_bytes());
        let columns: Vec<String> = reader
            .headers()
            .map_err(|e| Error::csv(path, Place::Line(1), FileOp::ReadHeader, e))?
            .iter()
            .map(str::to_string)
            .collect();
        let mut rows = Vec::new();
        for record in reader.records() {
            let record = record.map_err(|e| Error::csv(path, Place::File, FileOp::Read, e))?;
            if record.len() != columns.len() {
                let line = record.position().map_or(0, |p| p.line());
                return Err(InputError::line(
                    path,
                    line as usize,
                    format!(
                        "row has {} cells, the header has {}",
                        record.len(),
                        columns.len()
                    ),
                )
                .into());
            }
            rows.push(record.iter().map(str::to_string).collect());
        }
        Ok(ReadTable {
            table: Table { columns, rows },
            dropped_last_line: dropped,
        })
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
    pub fn create(path: &Path, columns: &[String]) -> Result<RowWriter, Error> {
        Self::start(path, columns, &[])
    }

    /// Continue `path` from `table`: its rows are kept (the file is
    /// rewritten atomically, which also removes an incomplete last line)
    /// and new rows are appended after them.
    pub fn resume(path: &Path, table: &Table) -> Result<RowWriter, Error> {
        Self::start(path, &table.columns, &table.rows)
    }

    fn start(path: &Path, columns: &[String], rows: &[Vec<String>]) -> Result<RowWriter, Error> {
        let csv_error = |op, e| Error::csv(path, Place::File, op, e);
        raylab::io::write_atomically(path, |tmp| {
            let mut w = csv::Writer::from_path(tmp).map_err(|e| csv_error(FileOp::Create, e))?;
            w.write_record(columns)
                .map_err(|e| csv_error(FileOp::Write, e))?;
            for row in rows {
                w.write_record(row)
                    .map_err(|e| csv_error(FileOp::Write, e))?;
            }
            w.flush().map_err(|e| Error::io(path, FileOp::Write, e))
        })?;
        let file = OpenOptions::new()
            .append(true)
            .open(path)
            .map_err(|e| Error::io(path, FileOp::OpenForAppending, e))?;
        Ok(RowWriter {
            path: path.to_path_buf(),
            writer: csv::WriterBuilder::new()
                .has_headers(false)
                .from_writer(file),
            width: columns.len(),
        })
    }

    /// Append one row and flush it to the file.
    pub fn append(&mut self, row: &[String]) -> Result<(), Error> {
        if row.len() != self.width {
            return Err(Error::Internal(format!(
                "{}: a row of {} cells for {} columns",
                self.path.display(),
                row.len(),
                self.width
            )));
        }
        self.writer
            .write_record(row)
            .and_then(|()| self.writer.flush().map_err(csv::Error::from))
            .map_err(|e| Error::csv(&self.path, Place::File, FileOp::AppendRow, e))
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
        let read = Table::read(&path).unwrap();
        assert!(!read.dropped_last_line);
        assert_eq!(read.table.rows, vec![vec!["x,1", "2"], vec!["y", "3"]]);
        let text = std::fs::read_to_string(&path).unwrap();
        std::fs::write(&path, &text[..text.len() - 2]).unwrap();
        let read = Table::read(&path).unwrap();
        assert!(read.dropped_last_line);
        assert_eq!(read.table.rows.len(), 1);
    }
}
