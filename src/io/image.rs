//! Image files: PNG (8-bit, sRGB-encoded) and OpenEXR (32-bit float, linear).
//! In memory an image is an `ndarray` of shape (height, width, 3) holding
//! linear RGB.

use super::{write_atomically, InputError};
use crate::math::{srgb_decode, srgb_encode};
use ndarray::Array3;
use std::path::Path;

/// Linear RGB image, shape (height, width, 3), row 0 at the top.
pub type LinearImage = Array3<f32>;

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
}
