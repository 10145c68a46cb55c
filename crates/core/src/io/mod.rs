//! Reading and writing files: meshes (OBJ, PLY, OFF, 3DS), scene files and
//! images. Readers return an [`InputError`] naming the file, the place in it
//! and what was expected; they never panic on bad input.

pub mod image;
pub mod input;
#[cfg(unix)]
pub mod interrupt;
pub mod mesh;
pub mod procedural;
pub mod scene_file;
pub mod toml_numbers;

use std::fmt;
use std::path::{Path, PathBuf};

pub use mesh::{read_mesh, MeshData};

/// Where in a file an error was found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Place {
    /// The file as a whole (missing, empty, unreadable).
    File,
    /// A 1-based line of a text file.
    Line(usize),
    /// A 1-based line and column of a text file.
    LineCol(usize, usize),
    /// A byte offset into a binary file.
    Byte(u64),
}

impl fmt::Display for Place {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Place::File => Ok(()),
            Place::Line(l) => write!(f, ":{l}"),
            Place::LineCol(l, c) => write!(f, ":{l}:{c}"),
            Place::Byte(b) => write!(f, ": at byte {b}"),
        }
    }
}

/// A problem with an input file: `path:line[:col]: message`, the form
/// compilers use, so editors can jump to it.
#[derive(Debug, Clone, thiserror::Error)]
#[error("{}{}: {}", path.display(), place, message)]
pub struct InputError {
    pub path: PathBuf,
    pub place: Place,
    pub message: String,
}

impl InputError {
    pub fn new(path: impl AsRef<Path>, place: Place, message: impl Into<String>) -> Self {
        Self {
            path: path.as_ref().to_path_buf(),
            place,
            message: message.into(),
        }
    }

    /// An error about the file as a whole.
    pub fn file(path: impl AsRef<Path>, message: impl Into<String>) -> Self {
        Self::new(path, Place::File, message)
    }

    /// An error at a 1-based line.
    pub fn line(path: impl AsRef<Path>, line: usize, message: impl Into<String>) -> Self {
        Self::new(path, Place::Line(line), message)
    }
}

/// A problem writing an output file: `path: message`. Nothing is left at
/// `path` when writing fails ([`write_atomically`]).
#[derive(Debug, Clone, thiserror::Error)]
#[error("{}: {}", path.display(), message)]
pub struct OutputError {
    pub path: PathBuf,
    pub message: String,
}

impl OutputError {
    pub fn new(path: impl AsRef<Path>, message: impl Into<String>) -> Self {
        Self {
            path: path.as_ref().to_path_buf(),
            message: message.into(),
        }
    }
}

/// 1-based line and column of a byte offset into `text`.
pub fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = &text.as_bytes()[..offset];
    let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
    let col = offset
        - before
            .iter()
            .rposition(|&b| b == b'\n')
            .map_or(0, |p| p + 1)
        + 1;
    (line, col)
}

/// The message of a TOML error in `text`. The parser leaves it empty for
/// some syntax errors (a control character in a comment, a value cut off
/// by the end of the file); then it says what is at the error's place.
pub fn toml_message(text: &str, e: &toml::de::Error) -> String {
    let message = e.message().trim();
    if !message.is_empty() {
        return message.to_string();
    }
    let found = e
        .span()
        .and_then(|span| text.get(span.start..))
        .and_then(|rest| rest.chars().next());
    match found {
        Some(c) => format!("TOML syntax error: unexpected {c:?}"),
        None => "TOML syntax error: the file ends in the middle of a statement".into(),
    }
}

/// Write a file atomically: the bytes go to a temporary name beside the
/// target, which is renamed into place only when complete, so a failed or
/// interrupted write never leaves a half-written output. Missing parent
/// folders are created. `write` may fail with any error that an
/// [`OutputError`] converts into (the caller's own error type).
pub fn write_atomically<E: From<OutputError>>(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), E>,
) -> Result<(), E> {
    let file_name = path
        .file_name()
        .ok_or_else(|| OutputError::new(path, "not a file name"))?;
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(file_name);
    tmp_name.push(format!(".{}.tmp", std::process::id()));
    let tmp = path.with_file_name(tmp_name);
    // `-o out/run-3/image.png` makes `out/run-3/` as a shell user expects.
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(|e| {
            OutputError::new(
                path,
                format!("cannot create its folder {}: {e}", parent.display()),
            )
        })?;
    }
    #[cfg(unix)]
    let _pending = interrupt::pending(&tmp);
    let result = write(&tmp).and_then(|()| {
        std::fs::rename(&tmp, path)
            .map_err(|e| OutputError::new(path, format!("cannot rename into place: {e}")).into())
    });
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// What a path names, for telling whether two paths are one file: an
/// existing file by its device and inode (so hard links and symbolic links
/// to it are the same file), a file still to be made by its folder's
/// canonical path and its name.
#[derive(Debug, PartialEq, Eq)]
enum FileId {
    #[cfg(unix)]
    Inode(u64, u64),
    Path(PathBuf),
}

fn file_id(path: &Path) -> FileId {
    #[cfg(unix)]
    if let Ok(meta) = std::fs::metadata(path) {
        use std::os::unix::fs::MetadataExt;
        return FileId::Inode(meta.dev(), meta.ino());
    }
    if let Ok(p) = path.canonicalize() {
        return FileId::Path(p);
    }
    let parent = path.parent().filter(|p| !p.as_os_str().is_empty());
    let dir = match parent {
        Some(d) => d.canonicalize().unwrap_or_else(|_| absolute(d)),
        None => std::env::current_dir().unwrap_or_default(),
    };
    FileId::Path(dir.join(path.file_name().unwrap_or_default()))
}

fn absolute(path: &Path) -> PathBuf {
    std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf())
}

/// Refuse, before any work is done, a command whose output would overwrite
/// one of its inputs or another of its outputs (`diff a.png a.png --out
/// a.png`, `render -o o.png --spp-map o.png`). Each path comes with the
/// role that names it in the message (`"--out"`, `"the scene"`).
pub fn check_outputs(
    inputs: &[(&str, &Path)],
    outputs: &[(&str, &Path)],
) -> Result<(), OutputError> {
    let inputs: Vec<_> = inputs.iter().map(|&(r, p)| (r, p, file_id(p))).collect();
    let mut seen: Vec<(&str, &Path, FileId)> = Vec::new();
    for &(role, path) in outputs {
        let id = file_id(path);
        let clash = inputs
            .iter()
            .map(|(r, p, i)| (r, p, i, "input"))
            .chain(seen.iter().map(|(r, p, i)| (r, p, i, "output")))
            .find(|(_, _, other, _)| **other == id);
        if let Some((other_role, other_path, _, kind)) = clash {
            return Err(OutputError::new(
                path,
                format!(
                    "{role} would overwrite {other_role}, an {kind} ({}); choose another path",
                    other_path.display()
                ),
            ));
        }
        seen.push((role, path, id));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::scene_file::{parse_scene, Overrides};
    use super::*;

    /// Syntax errors for which the TOML parser gives no message still get
    /// one (found by crates/lab/tests/fuzz.rs: a NUL byte in a comment, a scene cut
    /// off before a value).
    #[test]
    fn toml_errors_without_a_message_get_one() {
        let path = Path::new("s.toml");
        for (text, needle) in [
            ("# a comment\0\n[image]\n", "unexpected '\\0'"),
            ("[camera]\neye = ", "ends in the middle"),
        ] {
            let e = match parse_scene(text, path, &Overrides::default()) {
                Err(e) => e,
                Ok(_) => panic!("{text:?} parsed"),
            };
            assert_eq!(e.path, path);
            assert!(e.message.contains(needle), "{text:?}: {e}");
        }
    }

    #[test]
    fn an_output_may_not_be_an_input_or_another_output() {
        let dir = std::env::temp_dir().join(format!("raylab-outputs-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let a = dir.join("a.png");
        std::fs::write(&a, b"x").unwrap();
        // The same file by another spelling.
        let a2 = dir.join(".").join("a.png");
        let e = check_outputs(&[("TEST", &a)], &[("--out", &a2)]).unwrap_err();
        assert!(
            e.message.contains("--out would overwrite TEST, an input"),
            "{e}"
        );
        let o = dir.join("new.png");
        let e = check_outputs(&[], &[("--output", &o), ("--spp-map", &o)]).unwrap_err();
        assert!(
            e.message
                .contains("--spp-map would overwrite --output, an output"),
            "{e}"
        );
        assert!(check_outputs(&[("TEST", &a)], &[("--out", &o)]).is_ok());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
