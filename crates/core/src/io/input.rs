//! Every file raylab reads is opened here: only a regular file, and only
//! one of a size this kind of input can have. A FIFO given as a scene
//! would block the read forever, a directory or a device fails late with
//! a confusing message, and a 40 GB "scene" would be read into memory
//! before the parser could object; each is refused at once, naming the
//! file and what was expected.
//!
//! [`check`] looks at the file without opening it (a `stat`, which does
//! not block on a FIFO); [`read`] then opens it without blocking and checks
//! the opened file again, so a path swapped for a FIFO between the two is
//! refused too, and reads at most the limit.

use super::InputError;
use crate::film::memory::{self, Bytes};
use std::fs::{File, Metadata};
use std::io::Read;
use std::path::Path;

/// What an input file is, which sets its name in messages and the largest
/// size read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputKind {
    /// A scene file (TOML).
    Scene,
    /// An experiment manifest or an optimisation spec (TOML), or an
    /// experiment's meta.json.
    Manifest,
    /// A mesh file (OBJ, PLY, OFF, 3DS).
    Mesh,
    /// An image (PNG, EXR).
    Image,
    /// A table of results (an experiment's data.csv, a profile).
    Table,
}

impl InputKind {
    /// How the kind is named in messages.
    pub fn name(self) -> &'static str {
        match self {
            InputKind::Scene => "scene file",
            InputKind::Manifest => "manifest",
            InputKind::Mesh => "mesh file",
            InputKind::Image => "image",
            InputKind::Table => "table",
        }
    }

    /// The largest file of this kind that is read. Text formats are
    /// written by people or by raylab: the largest committed scene,
    /// manifest or spec is under 20 kB, and a data.csv of a full run under
    /// 1 MB, so 64 MiB and 1 GiB leave room for generated ones. Meshes and
    /// images are as large as the machine can hold (checked against its
    /// memory as well): the caps are far above the largest real models
    /// (the 6-million-triangle meshes of the Stanford repository are under
    /// 400 MB as PLY).
    pub fn limit(self) -> u64 {
        const MIB: u64 = 1 << 20;
        match self {
            InputKind::Scene | InputKind::Manifest => 64 * MIB,
            InputKind::Table => 1024 * MIB,
            InputKind::Mesh | InputKind::Image => 16 * 1024 * MIB,
        }
    }
}

/// What a non-regular file is, in words.
fn file_type_name(meta: &Metadata) -> &'static str {
    let t = meta.file_type();
    if t.is_dir() {
        return "a directory";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_socket() {
            return "a socket";
        }
        if t.is_char_device() || t.is_block_device() {
            return "a device";
        }
    }
    "not a regular file"
}

/// The checks of [`check`] on a file's metadata.
fn check_metadata(path: &Path, kind: InputKind, meta: &Metadata) -> Result<u64, InputError> {
    if !meta.is_file() {
        return Err(InputError::file(
            path,
            format!(
                "is {}; a {} must be a regular file",
                file_type_name(meta),
                kind.name()
            ),
        ));
    }
    let len = meta.len();
    if len > kind.limit() {
        return Err(InputError::file(
            path,
            format!(
                "is {}, larger than raylab reads as a {} ({})",
                Bytes(len.into()),
                kind.name(),
                Bytes(kind.limit().into())
            ),
        ));
    }
    memory::check(
        || format!("reading {} ({})", path.display(), kind.name()),
        len.into(),
    )
    .map_err(|e| InputError::file(path, e.to_string()))?;
    Ok(len)
}

/// Check, without opening it, that `path` is a regular file no larger than
/// its kind allows and than memory holds; returns its length. For readers
/// that open the file themselves (the image decoders).
pub fn check(path: &Path, kind: InputKind) -> Result<u64, InputError> {
    let meta = std::fs::metadata(path)
        .map_err(|e| InputError::file(path, format!("cannot read {}: {e}", kind.name())))?;
    check_metadata(path, kind, &meta)
}

/// Open `path` for reading, checked as by [`check`] before and after
/// opening (without blocking, so a FIFO cannot stall the open).
fn open(path: &Path, kind: InputKind) -> Result<(File, u64), InputError> {
    check(path, kind)?;
    let cannot = |e: std::io::Error| InputError::file(path, format!("cannot read: {e}"));
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options.open(path).map_err(cannot)?;
    let len = check_metadata(path, kind, &file.metadata().map_err(cannot)?)?;
    Ok((file, len))
}

/// The whole of `path`, a regular file of at most its kind's limit.
pub fn read(path: &Path, kind: InputKind) -> Result<Vec<u8>, InputError> {
    let (file, len) = open(path, kind)?;
    let mut bytes = Vec::with_capacity(len as usize);
    // A file that grew since it was checked is read up to the limit and
    // then refused.
    file.take(kind.limit() + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| InputError::file(path, format!("cannot read: {e}")))?;
    if bytes.len() as u64 > kind.limit() {
        return Err(InputError::file(
            path,
            format!("grew past {} while being read", Bytes(kind.limit().into())),
        ));
    }
    Ok(bytes)
}

/// The whole of `path` as UTF-8 text ([`read`]).
pub fn read_to_string(path: &Path, kind: InputKind) -> Result<String, InputError> {
    String::from_utf8(read(path, kind)?).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        InputError::new(
            path,
            super::Place::Byte(at as u64),
            format!("the {} is not UTF-8 text", kind.name()),
        )
    })
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;

    fn scratch(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("raylab-input-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// A FIFO is refused at once (reading it would block until a writer
    /// came), and so are a directory and a device.
    #[test]
    fn only_regular_files_are_read() {
        let dir = scratch("kinds");
        let fifo = dir.join("scene.toml");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: `c` is a live NUL-terminated path for the call.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        for (path, needle) in [
            (fifo.as_path(), "FIFO"),
            (dir.as_path(), "a directory"),
            (Path::new("/dev/zero"), "a device"),
        ] {
            let e = read(path, InputKind::Scene).unwrap_err();
            assert_eq!(e.path, path);
            assert!(e.message.contains(needle), "{e}");
            assert!(e.message.contains("must be a regular file"), "{e}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_file_over_its_kind_s_limit_is_refused_before_reading() {
        let dir = scratch("size");
        let path = dir.join("big.toml");
        let f = File::create(&path).unwrap();
        f.set_len(InputKind::Scene.limit() + 1).unwrap();
        let e = read(&path, InputKind::Scene).unwrap_err();
        assert!(
            e.message
                .contains("larger than raylab reads as a scene file"),
            "{e}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_missing_file_names_its_kind() {
        let e = read(Path::new("/nonexistent/raylab.obj"), InputKind::Mesh).unwrap_err();
        assert!(e.message.starts_with("cannot read mesh file: "), "{e}");
    }
}
