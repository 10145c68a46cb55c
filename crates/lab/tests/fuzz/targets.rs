//! What the fuzzer feeds: the readers (targets), each with its seeds and
//! its memory bound, and the checks on what a reader returns.

use raylab::io::mesh::{parse_3ds, parse_obj, parse_off, parse_ply, MeshData};
use raylab::io::procedural::{Procedural, MAX_TRIANGLES};
use raylab::io::scene_file::{parse_scene, Overrides};
use raylab::io::InputError;
use std::path::{Path, PathBuf};

/// One reader under test.
pub struct Target {
    pub name: &'static str,
    /// The extension its inputs are saved (and, for path readers, read) with.
    pub ext: &'static str,
    /// Inputs in the default budget (`make test`).
    pub default_inputs: u64,
    /// The memory bound: an input of `n` bytes may raise the allocated
    /// bytes by at most `k·n + c` (see [`bound`] for why these values).
    pub k: u64,
    pub c: u64,
    pub run: fn(&[u8], &Ctx) -> Verdict,
}

/// What an input did, when it did not panic.
pub enum Verdict {
    /// Read without error (the result passed its checks).
    Accepted,
    /// Refused with an error that named the file.
    Rejected,
    /// A contract was broken without a panic: an error that does not name
    /// the file, or a result that is not well formed.
    Broken(String),
}

/// Where the path readers find their inputs.
pub struct Ctx {
    /// A scratch folder, for the inputs of readers that take a path.
    pub dir: PathBuf,
    /// A folder `scenes/` inside a tree that also has `meshes/cube.obj`,
    /// so that a scene's `../meshes/cube.obj` resolves; every other mesh
    /// path (the CGAL meshes in `../external/`) does not.
    pub scene_path: PathBuf,
    pub manifest_path: PathBuf,
}

/// Procedural meshes (`[[mesh]] procedural = …`) are requests for work,
/// not input to bound by its size: a 40-byte line asks for up to
/// `MAX_TRIANGLES` = 4·10⁷. Each triangle a scene asks for adds
/// [`BYTES_PER_TRIANGLE`] to its memory bound. A scene asking for more than
/// this many (and no more than `MAX_TRIANGLES`, which the parser refuses)
/// is heavy: mutants of it are skipped, and an unmodified seed
/// (icosphere-l7.toml asks for 327 680 triangles, ~0.9 s to build) runs
/// in the campaign without the time limit.
pub const SCENE_TRIANGLES: u64 = 50_000;

/// What one generated triangle may hold: its vertices and normals in the
/// generator (~3·12 + 3·12 / shared), the triangle indices (12), the
/// scene's `Primitive` and shading data (~64), the BVH's build arrays and
/// nodes (~128), with 2× for vector growth. 1 KiB is comfortably above.
const BYTES_PER_TRIANGLE: u64 = 1024;

const MIB: u64 = 1 << 20;

/// Memory bound constants, `peak − before ≤ k·len + c`:
///
/// - Mesh readers, k = 64, c = 1 MiB. The densest text is a polygon face:
///   each further index costs 2 bytes of input (`0 `) and adds a triangle
///   (12 bytes) and an index in the polygon buffer (4), 8× the input;
///   vertex lines `0 0 0\n` (6 bytes) give 12 bytes of position (2×) and
///   normals as much again. Vectors grow by doubling and a moving realloc
///   briefly holds old and new (3× a vector's size), and OBJ goes through
///   tobj, which keeps its own copies (the text twice, as lossy UTF-8 and
///   with statements commented out; positions, texture coordinates and
///   normals as f32; an index map) before ours: 64 covers 8× under 3×
///   growth with a margin of 2.5. c covers fixed costs: error messages,
///   tobj's initial maps, a 3DS file's per-object state.
/// - Scenes and manifests (TOML), k = 1024, c = 16 MiB. The TOML parser
///   keeps a document tree with spans: a value of 2 bytes (`1,`) becomes
///   an item of ~100–200 bytes, and the deserialiser a second copy; a
///   scene then builds its primitives and accelerator (~300 bytes per
///   primitive from a `[[sphere]]` of ≥ 40 bytes). c covers a manifest's
///   sweeps, which a short range `{ from, to, step }` may expand to
///   `MAX_VALUES` = 10⁵ values (a few MB), and the loaded `cube.obj`.
/// - Images: compressed pixels legitimately expand, but the readers refuse
///   a header that declares more pixel data than its file could hold
///   (`crates/core/src/io/image.rs`): PNG scan lines at most 1032× the file (deflate's
///   limit), EXR pixels at most 2048×. From there, PNG: a 1-bit grey
///   pixel (1/8 byte of scan line) is decoded to a byte, converted to RGB8
///   (3 bytes) and to linear f32 RGB (12): 128 bytes per scan-line byte,
///   k = 1032·128. EXR: a pixel of one f16 channel (2 bytes) becomes RGBA
///   f32 in the decoder (16 bytes), then RGB f32 (12): 14 bytes per byte,
///   k = 2048·16 = 32768 (`read_exr_channels` needs 3×, run after).
///   c = 8 MiB for the decoders' fixed buffers and the EXR header.
pub fn targets() -> Vec<Target> {
    vec![
        Target {
            name: "obj",
            ext: "obj",
            default_inputs: 1500,
            k: 64,
            c: MIB,
            run: |b, _| mesh(parse_obj(b, Path::new("fuzz.obj")), "fuzz.obj"),
        },
        Target {
            name: "ply",
            ext: "ply",
            default_inputs: 1500,
            k: 64,
            c: MIB,
            run: |b, _| mesh(parse_ply(b, Path::new("fuzz.ply")), "fuzz.ply"),
        },
        Target {
            name: "off",
            ext: "off",
            default_inputs: 1500,
            k: 64,
            c: MIB,
            run: |b, _| mesh(parse_off(b, Path::new("fuzz.off")), "fuzz.off"),
        },
        Target {
            name: "3ds",
            ext: "3ds",
            default_inputs: 1500,
            k: 64,
            c: MIB,
            run: |b, _| mesh(parse_3ds(b, Path::new("fuzz.3ds")), "fuzz.3ds"),
        },
        Target {
            name: "scene",
            ext: "toml",
            default_inputs: 1000,
            k: 1024,
            c: 16 * MIB,
            run: run_scene,
        },
        Target {
            name: "manifest",
            ext: "toml",
            default_inputs: 1000,
            k: 1024,
            c: 16 * MIB,
            run: |b, ctx| {
                let text = String::from_utf8_lossy(b);
                match raylab_lab::experiment::parse_manifest(&text, &ctx.manifest_path) {
                    Ok(_) => Verdict::Accepted,
                    Err(e) => named(&e, &ctx.manifest_path),
                }
            },
        },
        Target {
            name: "png",
            ext: "png",
            default_inputs: 1000,
            k: 1032 * 128,
            c: 8 * MIB,
            run: |b, ctx| image(b, &ctx.dir.join("fuzz.png"), false),
        },
        Target {
            name: "exr",
            ext: "exr",
            default_inputs: 1000,
            k: 2048 * 16,
            c: 8 * MIB,
            run: |b, ctx| image(b, &ctx.dir.join("fuzz.exr"), true),
        },
    ]
}

/// The bound on the bytes an input of `len` bytes may allocate, plus an
/// allowance (procedural triangles).
pub fn bound(t: &Target, len: usize, allowance: u64) -> u64 {
    t.k * len as u64 + t.c + allowance
}

/// An error must name the file it is about.
fn named(e: &InputError, path: &Path) -> Verdict {
    let text = e.to_string();
    if e.path != path || !text.starts_with(&path.display().to_string()) {
        Verdict::Broken(format!(
            "the error does not name the file {}: {text}",
            path.display()
        ))
    } else if e.message.trim().is_empty() {
        Verdict::Broken(format!("empty error message: {text}"))
    } else {
        Verdict::Rejected
    }
}

/// A mesh reader's result: an error naming the file, or a well-formed mesh.
fn mesh(result: Result<MeshData, InputError>, name: &str) -> Verdict {
    let m = match result {
        Ok(m) => m,
        Err(e) => return named(&e, Path::new(name)),
    };
    let n = m.positions.len();
    if m.triangles.is_empty() {
        Verdict::Broken("a mesh without triangles was accepted".into())
    } else if let Some(t) = m
        .triangles
        .iter()
        .find(|t| t.iter().any(|&v| v as usize >= n))
    {
        Verdict::Broken(format!("triangle {t:?} indexes past {n} vertices"))
    } else if let Some(p) = m.positions.iter().find(|p| !p.is_finite()) {
        Verdict::Broken(format!("non-finite vertex {p}"))
    } else if !(m.normals.is_empty() || m.normals.len() == n) {
        Verdict::Broken(format!("{} normals for {n} vertices", m.normals.len()))
    } else if let Some(v) = m
        .normals
        .iter()
        .find(|v| !v.is_finite() || (v.length() - 1.0).abs() > 1e-3)
    {
        Verdict::Broken(format!("normal {v} is not unit length"))
    } else {
        Verdict::Accepted
    }
}

/// The triangles a scene's procedural meshes ask for, read from the TOML
/// before the scene is parsed (0 when it does not parse or asks for none).
pub fn procedural_triangles(text: &str) -> u64 {
    let Ok(table) = text.parse::<toml::Table>() else {
        return 0;
    };
    let Some(toml::Value::Array(meshes)) = table.get("mesh") else {
        return 0;
    };
    meshes
        .iter()
        .filter_map(|m| m.get("procedural"))
        .filter_map(|p| p.clone().try_into::<Procedural>().ok())
        .map(|p| p.triangle_count())
        .filter(|&n| n <= MAX_TRIANGLES)
        .fold(0u64, u64::saturating_add)
}

/// The procedural triangles an input asks for (0 but for scenes).
pub fn triangles(t: &Target, bytes: &[u8]) -> u64 {
    if t.name == "scene" {
        procedural_triangles(&String::from_utf8_lossy(bytes))
    } else {
        0
    }
}

/// The memory allowance for `triangles` procedural triangles.
pub fn allowance(triangles: u64) -> u64 {
    triangles.saturating_mul(BYTES_PER_TRIANGLE)
}

fn run_scene(b: &[u8], ctx: &Ctx) -> Verdict {
    let text = String::from_utf8_lossy(b);
    match parse_scene(&text, &ctx.scene_path, &Overrides::default()) {
        Ok(_) => Verdict::Accepted,
        Err(e) => named(&e, &ctx.scene_path),
    }
}

/// Write the bytes to `path` and read them with the readers `raylab diff`
/// uses: `read_image` for both formats and, for EXR, `read_exr_channels`.
fn image(b: &[u8], path: &Path, exr: bool) -> Verdict {
    if let Err(e) = std::fs::write(path, b) {
        return Verdict::Broken(format!("cannot write {}: {e}", path.display()));
    }
    let first = match raylab::io::image::read_image(path) {
        Ok(img) if img.dim().2 != 3 => {
            return Verdict::Broken(format!("image of shape {:?}", img.dim()))
        }
        Ok(_) => Verdict::Accepted,
        Err(e) => named(&e, path),
    };
    if !exr || matches!(first, Verdict::Broken(_)) {
        return first;
    }
    match raylab::io::image::read_exr_channels(path) {
        Ok(c) => match c
            .channels
            .iter()
            .find(|(_, v)| v.len() != c.width * c.height)
        {
            Some((name, v)) => Verdict::Broken(format!(
                "channel {name} has {} samples for {}×{}",
                v.len(),
                c.width,
                c.height
            )),
            None => first,
        },
        Err(e) => match named(&e, path) {
            Verdict::Rejected if matches!(first, Verdict::Accepted) => Verdict::Rejected,
            v => v,
        },
    }
}
