//! The binary encodings of a PLY body, little and big endian: fixed-size
//! scalars read through [`Body`], with errors that name the byte offset,
//! and whole fixed-size elements skipped with one bounds check. Part of the
//! PLY reader ([`super`]).

use super::header::{Element, Scalar};
use super::{skip_property, Body, Item};
use crate::io::{InputError, Place};
use std::path::Path;

/// A binary body, either byte order; errors by byte offset.
pub(super) struct BinaryBody<'a> {
    pub(super) path: &'a Path,
    /// The whole file, so offsets in errors are file offsets.
    pub(super) data: &'a [u8],
    pub(super) pos: usize,
    pub(super) big_endian: bool,
}

impl<'a> BinaryBody<'a> {
    /// Check that `n` bytes of `what` are there at the current position.
    fn need(&self, n: usize, what: &dyn std::fmt::Display) -> Result<(), InputError> {
        if self.data.len() - self.pos < n {
            return Err(InputError::new(
                self.path,
                Place::Byte(self.pos as u64),
                format!(
                    "truncated: expected {n} bytes of {what} at byte {}, file ends at {}",
                    self.pos,
                    self.data.len()
                ),
            ));
        }
        Ok(())
    }

    fn take(&mut self, n: usize, what: &dyn std::fmt::Display) -> Result<&'a [u8], InputError> {
        self.need(n, what)?;
        let bytes = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(bytes)
    }
}

/// The first `N` bytes of `b` as an array; callers pass at least `N`.
fn array<const N: usize>(b: &[u8]) -> [u8; N] {
    let mut a = [0; N];
    a.copy_from_slice(&b[..N]);
    a
}

impl Body for BinaryBody<'_> {
    fn path(&self) -> &Path {
        self.path
    }

    fn remaining(&self) -> usize {
        self.data.len().saturating_sub(self.pos)
    }

    fn place(&mut self) -> Place {
        Place::Byte(self.pos as u64)
    }

    fn begin_item(&mut self, element: &Element, item: Item) -> Result<(), InputError> {
        match element.fixed_size() {
            Some(size) => self.need(size, &item),
            None => Ok(()),
        }
    }

    fn scalar(&mut self, ty: Scalar, item: Item, _: &str) -> Result<f64, InputError> {
        let b = self.take(ty.size(), &item)?;
        let be = self.big_endian;
        Ok(match ty {
            Scalar::I8 => f64::from(b[0] as i8),
            Scalar::U8 => f64::from(b[0]),
            Scalar::I16 => f64::from(if be {
                i16::from_be_bytes(array(b))
            } else {
                i16::from_le_bytes(array(b))
            }),
            Scalar::U16 => f64::from(if be {
                u16::from_be_bytes(array(b))
            } else {
                u16::from_le_bytes(array(b))
            }),
            Scalar::I32 => f64::from(if be {
                i32::from_be_bytes(array(b))
            } else {
                i32::from_le_bytes(array(b))
            }),
            Scalar::U32 => f64::from(if be {
                u32::from_be_bytes(array(b))
            } else {
                u32::from_le_bytes(array(b))
            }),
            Scalar::F32 => f64::from(if be {
                f32::from_be_bytes(array(b))
            } else {
                f32::from_le_bytes(array(b))
            }),
            Scalar::F64 => {
                if be {
                    f64::from_be_bytes(array(b))
                } else {
                    f64::from_le_bytes(array(b))
                }
            }
        })
    }

    fn skip(&mut self, ty: Scalar, n: usize, item: Item, _: &str) -> Result<(), InputError> {
        let bytes = n.saturating_mul(ty.size());
        self.take(bytes, &item).map(|_| ())
    }

    fn skip_element(&mut self, element: &Element) -> Result<(), InputError> {
        match element.fixed_size() {
            // One bounds check for the whole element rather than per item.
            Some(size) => {
                let total = usize::try_from(element.count)
                    .ok()
                    .and_then(|c| c.checked_mul(size))
                    .unwrap_or(usize::MAX);
                let what = format!("the {} {} elements", element.count, element.name);
                self.take(total, &what).map(|_| ())
            }
            None => {
                for index in 0..element.count {
                    let item = Item {
                        element: &element.name,
                        index,
                    };
                    for p in &element.properties {
                        skip_property(self, p, item)?;
                    }
                }
                Ok(())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::parse_ply;
    use super::super::tests::XYZ;
    use crate::io::Place;
    use std::path::Path;

    #[test]
    fn negative_binary_list_length_is_an_error() {
        let mut bytes = format!(
            "ply\nformat binary_little_endian 1.0\nelement vertex 3\n{XYZ}element face 1\nproperty list int int vertex_indices\nend_header\n"
        )
        .into_bytes();
        let body_start = bytes.len();
        bytes.extend([0u8; 36]);
        bytes.extend((-1i32).to_le_bytes());
        let e = parse_ply(&bytes, Path::new("t.ply")).unwrap_err();
        assert_eq!(e.place, Place::Byte(body_start as u64 + 36));
        assert!(e.message.contains("negative"), "{e}");
    }
}
