//! Image files: PNG (8-bit, sRGB-encoded) and OpenEXR (32-bit float, linear).
//! In memory an image is an `ndarray` of shape (height, width, 3) holding
//! linear RGB.

use super::{write_atomically, InputError, OutputError};
use crate::film::{Film, PixelStats};
use crate::math::{srgb_decode, srgb_encode};
use ndarray::Array3;
use std::path::Path;

pub use crate::film::LinearImage;

/// The file formats raylab writes, chosen by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    Png,
    Exr,
}

impl ImageFormat {
    /// The format named by a path's extension (case-insensitive).
    pub fn from_path(path: &Path) -> Option<Self> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "png" => Some(Self::Png),
            "exr" => Some(Self::Exr),
            _ => None,
        }
    }
}

/// Quantise a linear image to 8-bit sRGB bytes (row-major RGB).
pub fn to_srgb8(img: &LinearImage) -> Vec<u8> {
    img.iter()
        .map(|&v| (srgb_encode(v) * 255.0 + 0.5).floor() as u8)
        .collect()
}

/// Write `img` to `path` as PNG or EXR (by extension), atomically.
pub fn write_image(path: &Path, img: &LinearImage) -> Result<(), OutputError> {
    let format = ImageFormat::from_path(path).ok_or_else(|| {
        OutputError::new(path, "unsupported output extension (expected .png or .exr)")
    })?;
    let (h, w, c) = img.dim();
    if c != 3 {
        return Err(OutputError::new(
            path,
            format!("an image must have 3 channels, this one has {c}"),
        ));
    }
    let mismatch = || OutputError::new(path, "image buffer size mismatch");
    write_atomically(path, |tmp| {
        let result = match format {
            ImageFormat::Png => {
                let buf = image::RgbImage::from_raw(w as u32, h as u32, to_srgb8(img))
                    .ok_or_else(mismatch)?;
                buf.save_with_format(tmp, image::ImageFormat::Png)
            }
            ImageFormat::Exr => {
                let data: Vec<f32> = img.iter().copied().collect();
                let buf =
                    image::Rgb32FImage::from_raw(w as u32, h as u32, data).ok_or_else(mismatch)?;
                buf.save_with_format(tmp, image::ImageFormat::OpenExr)
            }
        };
        result.map_err(|e| OutputError::new(path, format!("cannot write image: {e}")))
    })
}

/// The samples of one channel of an EXR file written by
/// [`write_exr_channels`], row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub enum ChannelData {
    F32(Vec<f32>),
    U32(Vec<u32>),
}

impl ChannelData {
    fn len(&self) -> usize {
        match self {
            Self::F32(v) => v.len(),
            Self::U32(v) => v.len(),
        }
    }
}

/// Write named channels of `width` × `height` samples to an OpenEXR file
/// (one layer, lossless ZIP compression), atomically. Channel names follow
/// the OpenEXR convention: `R`, `G`, `B` for colour, `layer.R` for a
/// layer's colour (e.g. `variance.R`); readers such as `image` find R, G, B
/// and ignore the rest.
pub fn write_exr_channels(
    path: &Path,
    width: usize,
    height: usize,
    channels: Vec<(&str, ChannelData)>,
) -> Result<(), OutputError> {
    use exr::prelude::*;
    for (name, data) in &channels {
        if data.len() != width * height {
            return Err(OutputError::new(
                path,
                format!(
                    "EXR channel `{name}` has {} samples, expected {width}×{height}",
                    data.len()
                ),
            ));
        }
    }
    let list = channels
        .into_iter()
        .map(|(name, data)| {
            let samples = match data {
                ChannelData::F32(v) => FlatSamples::F32(v),
                ChannelData::U32(v) => FlatSamples::U32(v),
            };
            AnyChannel::new(name, samples)
        })
        .collect();
    let layer = Layer::new(
        (width, height),
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(list),
    );
    write_atomically(path, |tmp| {
        Image::from_layer(layer)
            .write()
            .to_file(tmp)
            .map_err(|e| OutputError::new(path, format!("cannot write EXR: {e}")))
    })
}

/// Write a film as OpenEXR with its statistics: `R`, `G`, `B` = the
/// image (each pixel's mean, or the filtered value when a wider filter
/// made one), `variance.R`, `variance.G`, `variance.B` = the unbiased
/// sample variance of its samples (divide by `count` for the variance of
/// the mean), `count` = its number of samples (32-bit unsigned). `image`
/// is the film's [`Film::image`], which the caller has developed already
/// (a second copy would cost 12 bytes a pixel).
pub fn write_film_exr(path: &Path, film: &Film, image: &LinearImage) -> Result<(), OutputError> {
    let channel =
        |f: &dyn Fn(&PixelStats) -> f32| ChannelData::F32(film.pixels.iter().map(f).collect());
    let plane = |c: usize| {
        ChannelData::F32(
            image
                .index_axis(ndarray::Axis(2), c)
                .iter()
                .copied()
                .collect(),
        )
    };
    let channels = vec![
        ("R", plane(0)),
        ("G", plane(1)),
        ("B", plane(2)),
        ("variance.R", channel(&|p| p.variance().x)),
        ("variance.G", channel(&|p| p.variance().y)),
        ("variance.B", channel(&|p| p.variance().z)),
        (
            "count",
            ChannelData::U32(film.pixels.iter().map(|p| p.count).collect()),
        ),
    ];
    write_exr_channels(path, film.width as usize, film.height as usize, channels)
}

/// Every channel of an EXR layer, as read by [`read_exr_channels`].
#[derive(Clone, Debug, PartialEq)]
pub struct ExrChannels {
    pub width: usize,
    pub height: usize,
    /// (name, samples row-major) in the file's (alphabetical) order.
    pub channels: Vec<(String, Vec<f32>)>,
}

impl ExrChannels {
    /// The samples of the channel called `name`.
    pub fn get(&self, name: &str) -> Option<&[f32]> {
        self.channels
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_slice())
    }
}

/// Read every channel of an EXR file's first layer, by name, as f32
/// (unsigned-integer channels are converted exactly up to 2²⁴).
pub fn read_exr_channels(path: &Path) -> Result<ExrChannels, InputError> {
    use exr::prelude::*;
    check_declared_size(path, ImageFormat::Exr)?;
    let img = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| InputError::file(path, e.to_string()))?;
    let size = img.layer_data.size;
    let channels = img
        .layer_data
        .channel_data
        .list
        .iter()
        .map(|c| {
            (
                c.name.to_string(),
                c.sample_data.values_as_f32().collect::<Vec<f32>>(),
            )
        })
        .collect();
    Ok(ExrChannels {
        width: size.width(),
        height: size.height(),
        channels,
    })
}

/// The most bytes a pixel takes while [`read_image`] decodes it: the
/// decoder's image (at most RGBA in 32-bit floats, 16), its RGB copy (at
/// most 12) and the linear image returned (12).
pub const DECODE_BYTES_PER_PIXEL: u128 = 16 + 12 + 12;

/// The width and height an image file's header declares, read without
/// decoding it (the file checked as [`read_image`] checks it).
pub fn dimensions(path: &Path) -> Result<(u32, u32), InputError> {
    let format = ImageFormat::from_path(path).ok_or_else(|| {
        InputError::file(path, "unsupported image extension (expected .png or .exr)")
    })?;
    check_declared_size(path, format)?;
    image::ImageReader::open(path)
        .and_then(|r| r.with_guessed_format())
        .map_err(|e| InputError::file(path, format!("cannot read: {e}")))?
        .into_dimensions()
        .map_err(|e| InputError::file(path, e.to_string()))
}

/// Read a PNG (decoded from sRGB to linear) or EXR (taken as linear) into a
/// linear RGB image. Alpha is dropped. An image whose decoding would need
/// more memory than the machine has is refused before it is decoded.
pub fn read_image(path: &Path) -> Result<LinearImage, InputError> {
    let format = ImageFormat::from_path(path).ok_or_else(|| {
        InputError::file(path, "unsupported image extension (expected .png or .exr)")
    })?;
    let (w, h) = dimensions(path)?;
    crate::film::memory::check(
        || format!("decoding its {w}×{h} pixels"),
        u128::from(w) * u128::from(h) * DECODE_BYTES_PER_PIXEL,
    )
    .map_err(|e| InputError::file(path, e.to_string()))?;
    let dynimg = image::open(path).map_err(|e| InputError::file(path, e.to_string()))?;
    let (w, h) = (dynimg.width() as usize, dynimg.height() as usize);
    let data: Vec<f32> = match format {
        ImageFormat::Png => dynimg
            .to_rgb8()
            .into_raw()
            .into_iter()
            .map(|b| srgb_decode(b as f32 / 255.0))
            .collect(),
        ImageFormat::Exr => dynimg.to_rgb32f().into_raw(),
    };
    Array3::from_shape_vec((h, w, 3), data).map_err(|e| InputError::file(path, e.to_string()))
}

/// Deflate (PNG's image data; EXR's ZIP and PXR24) expands at most 1032:1:
/// a file of n bytes cannot hold more than 1032·n bytes of pixels.
const DEFLATE_MAX_RATIO: u64 = 1032;

/// The most pixel bytes an EXR file may declare per byte of file: above
/// deflate's 1032:1 (and PXR24's 4/3 of it for f32) and PIZ's Huffman
/// coding with run lengths (~410:1). (Lossy DWAA/DWAB, which can compress
/// further, is refused anyway: see [`check_declared_size`].)
const EXR_MAX_RATIO: u64 = 2048;

/// Refuse an image whose header declares more pixel data than its file
/// can hold compressed, before a decoder allocates room for it: a
/// 100-byte file that claims 60000×60000 pixels would otherwise cost
/// gigabytes. Files the decoder cannot read pass, for it to report.
///
/// EXR files in the lossy DWAA/DWAB compressions are refused: exr's DWA
/// decoder allocates the size a block states for its deflated part without
/// bounding it, so three flipped bits made it ask for 72 PB and abort the
/// process (found by crates/lab/tests/fuzz.rs). raylab writes ZIP.
fn check_declared_size(path: &Path, format: ImageFormat) -> Result<(), InputError> {
    let file_len = super::input::check(path, super::input::InputKind::Image)?;
    let (declared, ratio, what) = match format {
        ImageFormat::Png => {
            let mut header = [0u8; 29];
            let n = std::fs::File::open(path)
                .and_then(|mut f| std::io::Read::read(&mut f, &mut header))
                .map_err(|e| InputError::file(path, format!("cannot read: {e}")))?;
            match png_data_bytes(&header[..n]) {
                Some(d) => d,
                None => return Ok(()),
            }
        }
        ImageFormat::Exr => match exr::meta::MetaData::read_from_file(path, false) {
            Ok(meta) => {
                use exr::compression::Compression;
                let dwa = meta.headers.iter().find_map(|h| match h.compression {
                    Compression::DWAA(_) => Some("DWAA"),
                    Compression::DWAB(_) => Some("DWAB"),
                    _ => None,
                });
                if let Some(name) = dwa {
                    return Err(InputError::file(
                        path,
                        format!(
                            "{name} compression is not supported (its decoder trusts sizes \
                             stored in the file); convert the image to ZIP, PIZ or no compression"
                        ),
                    ));
                }
                exr_data_bytes(&meta)
            }
            Err(_) => return Ok(()),
        },
    };
    if declared > ratio.saturating_mul(file_len) {
        return Err(InputError::file(
            path,
            format!(
                "the header declares {what} ({declared} bytes of pixel data), more than a \
                 file of {file_len} bytes can hold (its compression expands at most {ratio}:1)"
            ),
        ));
    }
    Ok(())
}

/// From the start of a PNG file (signature and IHDR chunk), the bytes of
/// its filtered scan lines (what deflate must produce), the most they can
/// expand, and the size in words; `None` if this is no PNG header.
fn png_data_bytes(header: &[u8]) -> Option<(u64, u64, String)> {
    const SIGNATURE: &[u8] = b"\x89PNG\r\n\x1a\n";
    if header.len() < 29 || !header.starts_with(SIGNATURE) || header[12..16] != *b"IHDR" {
        return None;
    }
    let be = |at: usize| {
        u64::from(u32::from_be_bytes([
            header[at],
            header[at + 1],
            header[at + 2],
            header[at + 3],
        ]))
    };
    let (width, height) = (be(16), be(20));
    let samples = match header[25] {
        0 | 3 => 1, // grey, palette index
        4 => 2,     // grey and alpha
        2 => 3,     // RGB
        6 => 4,     // RGBA
        _ => return None,
    };
    let bits = width.saturating_mul(samples * u64::from(header[24]));
    // Each row: a filter byte and its samples, packed to whole bytes.
    let row = 1 + bits.div_ceil(8);
    Some((
        height.saturating_mul(row),
        DEFLATE_MAX_RATIO,
        format!("{width}×{height} pixels"),
    ))
}

/// The pixel bytes of an EXR file's flat layers at full resolution, the
/// most they can expand, and the size in words. A layer counts with its
/// data window or its display window, whichever is larger: the decoder
/// behind [`read_image`] returns the display window, filling what lies
/// outside the data window with zeros.
fn exr_data_bytes(meta: &exr::meta::MetaData) -> (u64, u64, String) {
    let mut total = 0u64;
    let mut sizes = Vec::new();
    for h in meta.headers.iter().filter(|h| !h.deep) {
        let area = |size: exr::math::Vec2<usize>| {
            (size.width() as u64).saturating_mul(size.height() as u64)
        };
        let display = h.shared_attributes.display_window.size;
        let size = if area(display) > area(h.layer_size) {
            display
        } else {
            h.layer_size
        };
        let (w, ht) = (size.width() as u64, size.height() as u64);
        let per_pixel: u64 = h
            .channels
            .list
            .iter()
            .map(|c| c.sample_type.bytes_per_sample() as u64)
            .sum();
        total = total.saturating_add(w.saturating_mul(ht).saturating_mul(per_pixel));
        sizes.push(format!("{w}×{ht}"));
    }
    let what = match sizes.len() {
        1 => format!("{} pixels", sizes[0]),
        _ => format!("layers of {} pixels", sizes.join(", ")),
    };
    (total, EXR_MAX_RATIO, what)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exr_round_trip_is_exact_and_png_within_quantisation() {
        let dir = tempfile::tempdir().unwrap();
        let img = Array3::from_shape_fn((3, 4, 3), |(y, x, c)| (y * 12 + x * 3 + c) as f32 / 36.0);
        let exr = dir.path().join("a.exr");
        write_image(&exr, &img).unwrap();
        assert_eq!(read_image(&exr).unwrap(), img);
        let png = dir.path().join("a.png");
        write_image(&png, &img).unwrap();
        let back = read_image(&png).unwrap();
        // 8-bit sRGB: one code step is at most ~1/255 in encoded space, which
        // is at most ~0.013 in linear space near 1 (slope of decode ≤ 2.4·1.055^…).
        for (a, b) in back.iter().zip(img.iter()) {
            assert!((a - b).abs() < 0.01, "{a} vs {b}");
        }
    }

    /// A header that declares more pixels than its file can hold is refused
    /// before anything is allocated for them (found by crates/lab/tests/fuzz.rs: an
    /// EXR of 2796 bytes made its decoder allocate 578 MB).
    #[test]
    fn declared_size_beyond_the_file_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let img = Array3::from_elem((3, 4, 3), 0.5f32);
        // PNG: width and height in the IHDR chunk (the CRC goes stale,
        // but the size check comes first).
        let png = dir.path().join("big.png");
        write_image(&png, &img).unwrap();
        let mut bytes = std::fs::read(&png).unwrap();
        bytes[16..20].copy_from_slice(&60000u32.to_be_bytes());
        bytes[20..24].copy_from_slice(&60000u32.to_be_bytes());
        std::fs::write(&png, &bytes).unwrap();
        let e = read_image(&png).unwrap_err();
        assert_eq!(e.path, png);
        assert!(e.message.contains("60000×60000 pixels"), "{e}");
        // EXR: xMax and yMax of the data window, then of the display
        // window alone (the decoder behind read_image returns the display
        // window: a 2.8 KB file made it allocate 289 MB).
        for window in ["dataWindow", "displayWindow"] {
            let exr = dir.path().join(format!("{window}.exr"));
            write_image(&exr, &img).unwrap();
            let mut bytes = std::fs::read(&exr).unwrap();
            let key = format!("{window}\0box2i\0");
            let at = bytes
                .windows(key.len())
                .position(|w| w == key.as_bytes())
                .unwrap()
                + key.len()
                + 4;
            bytes[at + 8..at + 12].copy_from_slice(&59999i32.to_le_bytes());
            bytes[at + 12..at + 16].copy_from_slice(&59999i32.to_le_bytes());
            std::fs::write(&exr, &bytes).unwrap();
            for e in [
                read_image(&exr).unwrap_err(),
                read_exr_channels(&exr).unwrap_err(),
            ] {
                assert_eq!(e.path, exr);
                assert!(e.message.contains("60000×60000 pixels"), "{window}: {e}");
            }
        }
    }

    /// DWAA and DWAB are refused before the decoder runs: exr's DWA
    /// decoder allocated the size a block states, 72 PB for a mutated file
    /// (found by crates/lab/tests/fuzz.rs; tests/data/fuzz/exr-dwaa-inflated-size.exr).
    #[test]
    fn dwa_compressed_exr_is_refused() {
        use exr::prelude::*;
        let dir = tempfile::tempdir().unwrap();
        for (name, compression) in [
            ("DWAA", Compression::DWAA(None)),
            ("DWAB", Compression::DWAB(None)),
        ] {
            let path = dir.path().join(format!("{name}.exr"));
            let samples = FlatSamples::F32((0..64).map(|i| i as f32 / 64.0).collect());
            let layer = Layer::new(
                (8, 8),
                LayerAttributes::default(),
                Encoding {
                    compression,
                    blocks: Blocks::ScanLines,
                    line_order: LineOrder::Increasing,
                },
                AnyChannels::sort(vec![AnyChannel::new("R", samples)].into()),
            );
            Image::from_layer(layer).write().to_file(&path).unwrap();
            for e in [
                read_image(&path).unwrap_err(),
                read_exr_channels(&path).unwrap_err(),
            ] {
                assert_eq!(e.path, path);
                assert!(e.message.contains("not supported"), "{name}: {e}");
            }
        }
    }

    /// A B44 block whose deltas run below zero: OpenEXR's decoder relies
    /// on unsigned wrap-around there, and exr's port panicked in builds
    /// with overflow checks (found by crates/lab/tests/fuzz.rs; Cargo.toml turns the
    /// checks off for exr). The file must read, not panic.
    #[test]
    fn b44_block_that_wraps_round_reads() {
        use exr::prelude::*;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("b44.exr");
        let (w, h) = (8usize, 4usize);
        let channel = |name: &str| {
            AnyChannel::new(
                name,
                FlatSamples::F16((0..w * h).map(|i| f16::from_f32(i as f32 / 7.0)).collect()),
            )
        };
        let layer = Layer::new(
            (w, h),
            LayerAttributes::default(),
            Encoding {
                compression: Compression::B44,
                blocks: Blocks::ScanLines,
                line_order: LineOrder::Increasing,
            },
            AnyChannels::sort(vec![channel("R"), channel("G"), channel("B")].into()),
        );
        Image::from_layer(layer).write().to_file(&path).unwrap();
        let mut bytes = std::fs::read(&path).unwrap();
        // The one chunk: after the header's final NUL comes the offset table
        // (one u64), then the chunk's y (i32), size (i32) and data. Every
        // 14-byte block becomes s0 = 0 with shift 12: s4 = s0 + 0 − bias.
        let nul = |from: usize| from + bytes[from..].iter().position(|&b| b == 0).unwrap();
        let mut at = 8; // magic number and version
        while bytes[at] != 0 {
            let type_end = nul(nul(at) + 1);
            let size = i32::from_le_bytes(bytes[type_end + 1..type_end + 5].try_into().unwrap());
            at = type_end + 5 + size as usize;
        }
        let header_end = at;
        let chunk = u64::from_le_bytes(bytes[header_end + 1..header_end + 9].try_into().unwrap());
        let data = chunk as usize + 8;
        let size = i32::from_le_bytes(bytes[data - 4..data].try_into().unwrap()) as usize;
        assert!(size < w * h * 6, "the chunk must be B44-compressed");
        for (i, b) in bytes[data..data + size].iter_mut().enumerate() {
            *b = if i % 14 == 2 { 0x30 } else { 0 };
        }
        std::fs::write(&path, &bytes).unwrap();
        // It decodes (to what the wrapped deltas give).
        assert_eq!(read_image(&path).unwrap().dim(), (h, w, 3));
        assert_eq!(read_exr_channels(&path).unwrap().channels.len(), 3);
    }

    /// Every channel comes back as written: f32 and u32 samples are stored
    /// losslessly, so equality is exact; and `image`'s reader (used for
    /// references and `raylab diff`) still finds the mean in R, G, B.
    #[test]
    fn exr_round_trip_of_statistics_channels() {
        let mut film = Film::new(3, 2);
        for (i, p) in film.pixels.iter_mut().enumerate() {
            for k in 0..=i {
                p.add(crate::math::Color::new(0.1 * k as f32, 0.5, 2.0 + i as f32));
            }
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.exr");
        write_film_exr(&path, &film, &film.image()).unwrap();
        let exr = read_exr_channels(&path).unwrap();
        assert_eq!((exr.width, exr.height), (3, 2));
        let get = |name: &str| {
            exr.get(name)
                .unwrap_or_else(|| panic!("no channel {name}"))
                .to_vec()
        };
        let var = film.variance_image();
        for (i, p) in film.pixels.iter().enumerate() {
            let (y, x) = (i / 3, i % 3);
            assert_eq!(get("R")[i], p.mean.x);
            assert_eq!(get("B")[i], p.mean.z);
            assert_eq!(get("variance.R")[i], var[[y, x, 0]]);
            assert_eq!(get("variance.G")[i], var[[y, x, 1]]);
            assert_eq!(get("count")[i], p.count as f32);
        }
        assert!(var[[1, 2, 0]] > 0.0, "the test needs a non-zero variance");
        let back = read_image(&path).unwrap();
        assert_eq!(back, film.image());
    }
}
