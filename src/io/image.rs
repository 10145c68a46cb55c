//! Image files: PNG (8-bit, sRGB-encoded) and OpenEXR (32-bit float, linear).
//! In memory an image is an `ndarray` of shape (height, width, 3) holding
//! linear RGB.

use super::{write_atomically, InputError};
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
pub fn write_image(path: &Path, img: &LinearImage) -> anyhow::Result<()> {
    let format = ImageFormat::from_path(path).ok_or_else(|| {
        anyhow::anyhow!(
            "{}: unsupported output extension (expected .png or .exr)",
            path.display()
        )
    })?;
    let (h, w, c) = img.dim();
    anyhow::ensure!(c == 3, "image must have 3 channels, has {c}");
    write_atomically(path, |tmp| {
        let result = match format {
            ImageFormat::Png => {
                let buf = image::RgbImage::from_raw(w as u32, h as u32, to_srgb8(img))
                    .ok_or_else(|| anyhow::anyhow!("image buffer size mismatch"))?;
                buf.save_with_format(tmp, image::ImageFormat::Png)
            }
            ImageFormat::Exr => {
                let data: Vec<f32> = img.iter().copied().collect();
                let buf = image::Rgb32FImage::from_raw(w as u32, h as u32, data)
                    .ok_or_else(|| anyhow::anyhow!("image buffer size mismatch"))?;
                buf.save_with_format(tmp, image::ImageFormat::OpenExr)
            }
        };
        result.map_err(|e| anyhow::anyhow!("{}: cannot write image: {e}", path.display()))
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
) -> anyhow::Result<()> {
    use exr::prelude::*;
    for (name, data) in &channels {
        anyhow::ensure!(
            data.len() == width * height,
            "EXR channel `{name}` has {} samples, expected {width}×{height}",
            data.len()
        );
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
            .map_err(|e| anyhow::anyhow!("{}: cannot write EXR: {e}", path.display()))
    })
}

/// Write a film as OpenEXR with its statistics: `R`, `G`, `B` = the
/// image (each pixel's mean, or the filtered value when a wider filter
/// made one), `variance.R`, `variance.G`, `variance.B` = the unbiased
/// sample variance of its samples (divide by `count` for the variance of
/// the mean), `count` = its number of samples (32-bit unsigned).
pub fn write_film_exr(path: &Path, film: &Film) -> anyhow::Result<()> {
    let channel =
        |f: &dyn Fn(&PixelStats) -> f32| ChannelData::F32(film.pixels.iter().map(f).collect());
    let image = film.image();
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

/// Read a PNG (decoded from sRGB to linear) or EXR (taken as linear) into a
/// linear RGB image. Alpha is dropped.
pub fn read_image(path: &Path) -> Result<LinearImage, InputError> {
    let format = ImageFormat::from_path(path).ok_or_else(|| {
        InputError::file(path, "unsupported image extension (expected .png or .exr)")
    })?;
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
        write_film_exr(&path, &film).unwrap();
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
