//! The ASCII encoding of a PLY body: whitespace-separated numbers, read
//! value by value through [`Body`], with errors that name the line. Part of
//! the PLY reader ([`super`]).

use super::header::{Element, Scalar};
use super::{Body, Item};
use crate::io::mesh::show;
use crate::io::{InputError, Place};
use std::path::Path;

/// An ASCII body: whitespace-separated numbers, errors by line.
pub(super) struct AsciiBody<'a> {
    pub(super) path: &'a Path,
    pub(super) data: &'a [u8],
    pub(super) pos: usize,
    /// Line number at `pos`.
    pub(super) line: usize,
    /// Line of the last value read, where "file ends" is reported: the
    /// line after the final line end would point at nothing.
    pub(super) last_line: usize,
}

impl<'a> AsciiBody<'a> {
    fn skip_space(&mut self) {
        while let Some(&b) = self.data.get(self.pos) {
            if !b.is_ascii_whitespace() {
                break;
            }
            if b == b'\n' {
                self.line += 1;
            }
            self.pos += 1;
        }
    }

    fn word(&mut self, item: Item, property: &str) -> Result<&'a [u8], InputError> {
        self.skip_space();
        let rest = &self.data[self.pos.min(self.data.len())..];
        let len = rest
            .iter()
            .position(u8::is_ascii_whitespace)
            .unwrap_or(rest.len());
        if len == 0 {
            return Err(InputError::line(
                self.path,
                self.last_line,
                format!("file ends while reading `{property}` of {item}"),
            ));
        }
        self.pos += len;
        self.last_line = self.line;
        Ok(&rest[..len])
    }
}

impl Body for AsciiBody<'_> {
    fn path(&self) -> &Path {
        self.path
    }

    fn remaining(&self) -> usize {
        self.data.len().saturating_sub(self.pos)
    }

    fn place(&mut self) -> Place {
        self.skip_space();
        Place::Line(self.line)
    }

    fn begin_item(&mut self, _: &Element, _: Item) -> Result<(), InputError> {
        Ok(())
    }

    fn scalar(&mut self, ty: Scalar, item: Item, property: &str) -> Result<f64, InputError> {
        let word = self.word(item, property)?;
        let line = self.line;
        let bad = |why: &str| {
            InputError::line(
                self.path,
                line,
                format!("{item}: `{property}` is `{}`, {why}", show(word)),
            )
        };
        let text = std::str::from_utf8(word).map_err(|_| bad("not a number"))?;
        match ty.integer_range() {
            Some((lo, hi)) => {
                let v: i64 = text
                    .parse()
                    .map_err(|_| bad(&format!("not an integer ({})", ty.name())))?;
                if !(lo..=hi).contains(&v) {
                    return Err(bad(&format!("out of the range of {}", ty.name())));
                }
                Ok(v as f64)
            }
            None => text.parse().map_err(|_| bad("not a number")),
        }
    }

    fn skip(&mut self, ty: Scalar, n: usize, item: Item, property: &str) -> Result<(), InputError> {
        for _ in 0..n {
            self.scalar(ty, item, property)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{ascii, parse, XYZ};
    use crate::io::Place;

    #[test]
    fn ascii_body_errors_name_the_line() {
        let header = format!(
            "element vertex 3\n{XYZ}element face 1\nproperty list uchar int vertex_indices\n"
        );
        for (body, line, needle) in [
            ("0 0 0\n1 0 0\n0 1\n", 12, "file ends"),
            ("0 0 0\n1 0 0\n0 x 0\n3 0 1 2\n", 12, "not a number"),
            ("0 0 0\n1 0 0\n0 1 0\n300 0 1 2\n", 13, "range of uchar"),
            ("0 0 0\n1 0 0\n0 1 0\n3 0 1 -2\n", 13, "out of range"),
            ("0 0 0\n1 0 0\n0 1 0\n2 0 1\n", 13, "at least 3"),
        ] {
            let e = parse(&ascii(&header, body)).unwrap_err();
            assert_eq!(e.place, Place::Line(line), "{e}");
            assert!(e.message.contains(needle), "{e}");
        }
    }
}
