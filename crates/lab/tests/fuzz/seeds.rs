//! The seeds: every real file of each format, and small images made here
//! with the library's writers (and the `image` and `exr` crates, for the
//! pixel types and compressions raylab does not write itself).
//!
//! In the default budget a seed longer than [`DEFAULT_SEED_BYTES`] is cut
//! to its first 64 KiB: the big CGAL meshes (armadillo.off is 1.6 MB)
//! would make each input take milliseconds, and their headers and first
//! vertices, which the prefix keeps, are where the reader's decisions are.
//! The campaign takes every file whole.

use std::path::{Path, PathBuf};

/// Seeds are cut to this length in the default budget.
pub const DEFAULT_SEED_BYTES: usize = 64 << 10;

/// One seed file.
pub struct Seed {
    /// Where it came from (a path, or how it was made).
    pub name: String,
    pub bytes: Vec<u8>,
}

fn root() -> PathBuf {
    raylab_testkit::repo().to_path_buf()
}

/// Files directly in `dir` whose extension (case-insensitive) is one of
/// `exts`, or every file when `exts` is empty; sorted.
fn files(dir: &Path, exts: &[&str]) -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e} (run scripts/fetch-data)", dir.display()))
        .map(|e| e.expect("directory entry").path())
        .filter(|p| p.is_file())
        .filter(|p| {
            exts.is_empty()
                || p.extension().is_some_and(|e| {
                    exts.contains(&e.to_string_lossy().to_ascii_lowercase().as_str())
                })
        })
        .collect();
    out.sort();
    out
}

/// Files with no extension (assimp's `formatDetection` samples).
fn bare(dir: &Path) -> Vec<PathBuf> {
    files(dir, &[])
        .into_iter()
        .filter(|p| p.extension().is_none())
        .collect()
}

/// The files of a folder tree with extension `ext`, sorted.
fn tree(dir: &Path, ext: &str) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for p in files(dir, &[]) {
        if p.extension().is_some_and(|e| e == ext) {
            out.push(p);
        }
    }
    for entry in std::fs::read_dir(dir).expect("scene folder") {
        let p = entry.expect("directory entry").path();
        if p.is_dir() {
            out.extend(tree(&p, ext));
        }
    }
    out.sort();
    out
}

/// The real files each target starts from.
pub fn real_files(target: &str) -> Vec<PathBuf> {
    let r = root();
    let ext = r.join("data/external");
    assert!(
        ext.join(".complete").is_file(),
        "{} is missing or incomplete: run scripts/fetch-data (make test does)",
        ext.display()
    );
    let assimp = ext.join("assimp");
    let broken = r.join("tests/data/broken");
    let fuzz = r.join("tests/data/fuzz");
    let mut out = match target {
        "obj" => [
            files(&assimp.join("OBJ"), &["obj", "mtl"]),
            files(&r.join("data/meshes"), &["obj"]),
        ]
        .concat(),
        "ply" => [
            files(&ext.join("cgal"), &["ply"]),
            files(&assimp.join("PLY"), &["ply"]),
        ]
        .concat(),
        "off" => [
            files(&ext.join("cgal"), &["off", "stl"]),
            files(&assimp.join("OFF"), &["off"]),
            bare(&assimp.join("OFF")),
        ]
        .concat(),
        "3ds" => [
            files(&assimp.join("3DS"), &["3ds", "txt"]),
            bare(&assimp.join("3DS")),
        ]
        .concat(),
        "scene" => tree(&r.join("data/scenes"), "toml"),
        "manifest" => files(&r.join("analysis"), &["toml"]),
        "png" => [
            files(&assimp.join("3DS"), &["png"]),
            files(&r.join("tests/data/png"), &["png"]),
        ]
        .concat(),
        "exr" => Vec::new(),
        other => panic!("no target {other}"),
    };
    // assimp's deliberately broken files go to every mesh reader, and our
    // own broken files to theirs.
    if matches!(target, "obj" | "ply" | "off" | "3ds") {
        out.extend(files(&assimp.join("invalid"), &[]));
        out.extend(files(&broken, &[target]));
    }
    // The inputs the fuzzer found problems with, `TARGET-what.EXT`.
    if fuzz.is_dir() {
        let prefix = format!("{target}-");
        out.extend(files(&fuzz, &[]).into_iter().filter(|p| {
            p.file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with(&prefix))
        }));
    }
    out
}

/// The seeds of a target: its real files (cut to [`DEFAULT_SEED_BYTES`]
/// when `whole` is false) and, for the image readers, images made in `dir`.
pub fn seeds(target: &str, whole: bool, dir: &Path) -> Vec<Seed> {
    let mut out: Vec<Seed> = real_files(target)
        .into_iter()
        .map(|p| {
            let mut bytes = std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            let mut name = p.strip_prefix(root()).unwrap_or(&p).display().to_string();
            if !whole && bytes.len() > DEFAULT_SEED_BYTES {
                bytes.truncate(DEFAULT_SEED_BYTES);
                name += " (first 64 KiB)";
            }
            Seed { name, bytes }
        })
        .collect();
    match target {
        "png" => out.extend(made_pngs(dir)),
        "exr" => out.extend(made_exrs(dir)),
        _ => {}
    }
    out
}

/// A small test pattern, linear RGB in [0, 1.5] (some values above 1).
fn pattern(w: usize, h: usize) -> ndarray::Array3<f32> {
    ndarray::Array3::from_shape_fn((h, w, 3), |(y, x, c)| {
        ((x * 7 + y * 13 + c * 5) % 16) as f32 / 10.0
    })
}

fn made(path: &Path, what: &str) -> Seed {
    Seed {
        name: format!("{what} (made by the fuzzer)"),
        bytes: std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())),
    }
}

/// PNGs in every colour type and depth the decoder handles.
fn made_pngs(dir: &Path) -> Vec<Seed> {
    let mut out = Vec::new();
    let p = dir.join("seed.png");
    raylab::io::image::write_image(&p, &pattern(7, 5)).expect("write PNG seed");
    out.push(made(&p, "7×5 RGB8 by io::image::write_image"));
    let (w, h) = (5u32, 4u32);
    let v = |x: u32, y: u32, c: u32| ((x * 40 + y * 60 + c * 90) % 256) as u8;
    let images: Vec<(&str, image::DynamicImage)> = vec![
        (
            "L8",
            image::GrayImage::from_fn(w, h, |x, y| image::Luma([v(x, y, 0)])).into(),
        ),
        (
            "LA8",
            image::GrayAlphaImage::from_fn(w, h, |x, y| image::LumaA([v(x, y, 0), v(x, y, 1)]))
                .into(),
        ),
        (
            "RGBA8",
            image::RgbaImage::from_fn(w, h, |x, y| {
                image::Rgba([v(x, y, 0), v(x, y, 1), v(x, y, 2), 200])
            })
            .into(),
        ),
        (
            "L16",
            image::ImageBuffer::<image::Luma<u16>, _>::from_fn(w, h, |x, y| {
                image::Luma([u16::from(v(x, y, 0)) * 257])
            })
            .into(),
        ),
        (
            "RGB16",
            image::ImageBuffer::<image::Rgb<u16>, _>::from_fn(w, h, |x, y| {
                image::Rgb([1000 * x as u16, 3000 * y as u16, 65535])
            })
            .into(),
        ),
        (
            "1×1 RGB8",
            image::RgbImage::from_pixel(1, 1, image::Rgb([1, 2, 3])).into(),
        ),
    ];
    for (what, img) in images {
        let p = dir.join(format!(
            "seed-{}.png",
            what.replace('×', "x").replace(' ', "-")
        ));
        img.save_with_format(&p, image::ImageFormat::Png)
            .expect("write PNG seed");
        out.push(made(&p, what));
    }
    out
}

/// EXRs: raylab's two writers, then every compression the `exr` crate
/// writes, with f16, f32 and u32 channels, in scan lines and in tiles.
fn made_exrs(dir: &Path) -> Vec<Seed> {
    use exr::prelude::*;
    let mut out = Vec::new();
    let p = dir.join("seed.exr");
    raylab::io::image::write_image(&p, &pattern(7, 5)).expect("write EXR seed");
    out.push(made(&p, "7×5 RGB by io::image::write_image"));
    let mut film = raylab::film::Film::new(4, 3);
    for (i, px) in film.pixels.iter_mut().enumerate() {
        for k in 0..=i % 3 {
            px.add(raylab::math::Color::new(0.1 * k as f32, 0.5, i as f32));
        }
    }
    let p = dir.join("seed-film.exr");
    raylab::io::image::write_film_exr(&p, &film, &film.image()).expect("write EXR seed");
    out.push(made(&p, "4×3 film by io::image::write_film_exr"));

    let (w, h) = (16usize, 12usize);
    let value = |i: usize| ((i * 37) % 101) as f32 / 25.0;
    let compressions = [
        ("uncompressed", Compression::Uncompressed),
        ("RLE", Compression::RLE),
        ("ZIP1", Compression::ZIP1),
        ("ZIP16", Compression::ZIP16),
        ("PIZ", Compression::PIZ),
        ("PXR24", Compression::PXR24),
        ("B44", Compression::B44),
        ("B44A", Compression::B44A),
        ("DWAA", Compression::DWAA(None)),
        ("DWAB", Compression::DWAB(None)),
    ];
    for (k, (what, compression)) in compressions.into_iter().enumerate() {
        let blocks = if k % 2 == 0 {
            Blocks::ScanLines
        } else {
            Blocks::Tiles(Vec2(8, 8))
        };
        let channels = AnyChannels::sort(
            vec![
                AnyChannel::new(
                    "R",
                    FlatSamples::F16((0..w * h).map(|i| f16::from_f32(value(i))).collect()),
                ),
                AnyChannel::new(
                    "G",
                    FlatSamples::F32((0..w * h).map(|i| value(i + 1)).collect()),
                ),
                AnyChannel::new(
                    "B",
                    FlatSamples::F16((0..w * h).map(|i| f16::from_f32(value(i + 2))).collect()),
                ),
                AnyChannel::new(
                    "count",
                    FlatSamples::U32((0..w * h).map(|i| i as u32).collect()),
                ),
            ]
            .into(),
        );
        let encoding = Encoding {
            compression,
            blocks,
            line_order: LineOrder::Increasing,
        };
        let layer = Layer::new((w, h), LayerAttributes::default(), encoding, channels);
        let p = dir.join(format!("seed-{what}.exr"));
        match Image::from_layer(layer).write().to_file(&p) {
            Ok(()) => out.push(made(&p, &format!("16×12 {what}, {blocks:?}"))),
            // A compression the crate cannot write is no seed; say so.
            Err(e) => eprintln!("fuzz: no {what} EXR seed: {e}"),
        }
    }
    out
}
