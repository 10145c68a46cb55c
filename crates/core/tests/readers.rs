//! The mesh readers against real files — CGAL's data meshes and assimp's
//! test models, installed by `scripts/fetch-data` into `data/external/` —
//! and against the hand-made broken files in `tests/data/broken/`.
//!
//! Expected counts come from the files themselves (OFF headers, face lines
//! counted here independently of the reader) or from assimp's and CGAL's
//! descriptions of the models, never from a previous run of our reader.

use glam::Vec3;
use proptest::prelude::*;
use raylab::io::mesh::{parse_3ds, parse_obj, parse_off, parse_ply, MESH_EXTENSIONS};
use raylab::io::{read_mesh, InputError, MeshData, Place};
use std::path::{Path, PathBuf};

/// A path under `data/external/`, after checking that the set-up ran.
fn external(relative: &str) -> PathBuf {
    let root = raylab_testkit::repo().join("data/external");
    assert!(
        root.join(".complete").is_file(),
        "{} is missing or incomplete: run scripts/fetch-data (make test does)",
        root.display()
    );
    root.join(relative)
}

fn broken(name: &str) -> PathBuf {
    raylab_testkit::repo().join("tests/data/broken").join(name)
}

/// Files in a folder with one of our mesh extensions, sorted.
fn mesh_files(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e} (run scripts/fetch-data)", dir.display()))
        .map(|entry| entry.expect("directory entry").path())
        .filter(|p| {
            p.extension().is_some_and(|e| {
                MESH_EXTENSIONS.contains(&e.to_string_lossy().to_ascii_lowercase().as_str())
            })
        })
        .collect();
    files.sort();
    files
}

fn read(path: &Path) -> MeshData {
    read_mesh(path).unwrap_or_else(|e| panic!("{e}"))
}

/// The invariants of every mesh a reader returns.
fn assert_well_formed(mesh: &MeshData, path: &Path) {
    let n = mesh.positions.len();
    assert!(!mesh.triangles.is_empty(), "{}", path.display());
    assert!(
        mesh.triangles.iter().flatten().all(|&v| (v as usize) < n),
        "{}: index out of range",
        path.display()
    );
    assert!(mesh.positions.iter().all(|p| p.is_finite()));
    assert!(mesh.normals.is_empty() || mesh.normals.len() == n);
    // Unit normals: f32 normalisation is good to a few ulps, 1e-5 is ample.
    assert!(mesh.normals.iter().all(|v| (v.length() - 1.0).abs() < 1e-5));
}

/// Vertex and triangle counts of an OFF file, worked out here from its
/// lines: the header counts, and each face line's `n` giving n − 2
/// triangles of its fan.
fn off_expected_counts(path: &Path) -> (usize, usize) {
    let text = std::fs::read_to_string(path).expect("OFF file is text");
    let mut lines = text
        .lines()
        .map(|l| l.split('#').next().unwrap_or("").trim())
        .filter(|l| !l.is_empty());
    let header: Vec<&str> = lines.next().unwrap().split_whitespace().collect();
    let counts: Vec<usize> = if header.len() > 1 {
        header[1..].iter().map(|w| w.parse().unwrap()).collect()
    } else {
        let line = lines.next().unwrap();
        line.split_whitespace()
            .map(|w| w.parse().unwrap())
            .collect()
    };
    let (nv, nf) = (counts[0], counts[1]);
    let triangles = lines
        .skip(nv)
        .take(nf)
        .map(|l| {
            l.split_whitespace()
                .next()
                .unwrap()
                .parse::<usize>()
                .unwrap()
                - 2
        })
        .sum();
    (nv, triangles)
}

fn bounds(mesh: &MeshData) -> (Vec3, Vec3) {
    mesh.positions
        .iter()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| {
            (lo.min(p), hi.max(p))
        })
}

// ---------------------------------------------------------------- CGAL (OFF)

#[test]
fn cgal_camel() {
    let path = external("cgal/camel.off");
    let mesh = read(&path);
    assert_eq!(mesh.positions.len(), 9770);
    assert_eq!(mesh.triangles.len(), 19536);
    assert!(mesh.normals.is_empty());
    assert_well_formed(&mesh, &path);
}

#[test]
fn cgal_counts_match_their_headers() {
    for (name, vertices, triangles) in [
        ("ChineseDragon-10kv.off", 10000, 19994),
        ("armadillo.off", 26002, 52000),
        ("bunny00.off", 37706, 75408),
        ("refined_elephant.off", 44460, 88928),
        // Six quads, each a fan of two triangles.
        ("cube_quad.off", 8, 12),
    ] {
        let path = external(&format!("cgal/{name}"));
        let mesh = read(&path);
        assert_eq!(
            (mesh.positions.len(), mesh.triangles.len()),
            (vertices, triangles),
            "{name}"
        );
        assert_eq!(off_expected_counts(&path), (vertices, triangles), "{name}");
        assert_well_formed(&mesh, &path);
    }
}

#[test]
fn every_cgal_off_reads_with_the_counts_of_its_lines() {
    let files: Vec<PathBuf> = mesh_files(&external("cgal"))
        .into_iter()
        .filter(|p| p.extension().is_some_and(|e| e == "off"))
        .collect();
    assert!(files.len() > 100, "expected CGAL's ~140 OFF meshes");
    for path in files {
        let mesh = read(&path);
        assert_eq!(
            (mesh.positions.len(), mesh.triangles.len()),
            off_expected_counts(&path),
            "{}",
            path.display()
        );
        assert_well_formed(&mesh, &path);
    }
}

#[test]
fn cgal_sphere_ply_and_off_agree() {
    let off = read(&external("cgal/sphere.off"));
    let ply = read(&external("cgal/sphere.ply"));
    assert_eq!(off.triangles.len(), 320);
    assert_eq!(ply.triangles.len(), off.triangles.len());
    assert_eq!(ply.positions.len(), off.positions.len());
}

// ------------------------------------------------------- assimp OBJ, PLY, OFF

/// assimp test files that are not triangle meshes we can read, and a word
/// the error must contain.
const ASSIMP_NOT_MESHES: [(&str, &str); 9] = [
    ("OBJ/box_UTF16BE.obj", "UTF-16"),
    // `3.1+e2` is not a number in any grammar we follow.
    ("OBJ/number_formats.obj", "not a number"),
    ("OBJ/point_cloud.obj", "no triangles"),
    ("OBJ/testline.obj", "no triangles"),
    ("OBJ/testpoints.obj", "no triangles"),
    ("OFF/invalid.off", "at least 3"),
    // Its header declares a list in the vertex element that the body lacks.
    ("PLY/issue623.ply", "not an integer"),
    ("PLY/points.ply", "no triangles"),
    // 69 bytes short of its header's 70051 × 31: bytes were lost (a
    // text-mode copy), and vertex 626 on decode as garbage (y = −1.4e19,
    // beyond math::MAX_COORDINATE; vertex 714 is the first non-finite).
    (
        "PLY/pond.0.ply",
        "vertex 626 [-9.65447e-27, -1.3783255e19, -3.2367094e-19] lies beyond",
    ),
];

#[test]
fn every_assimp_obj_ply_off_mesh_reads() {
    let mut read_ok = 0;
    for dir in ["OBJ", "PLY", "OFF"] {
        for path in mesh_files(&external(&format!("assimp/{dir}"))) {
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            let expected_error = ASSIMP_NOT_MESHES
                .iter()
                .find(|(f, _)| *f == format!("{dir}/{name}"));
            match (read_mesh(&path), expected_error) {
                (Ok(mesh), None) => {
                    assert_well_formed(&mesh, &path);
                    read_ok += 1;
                }
                (Err(e), Some((_, needle))) => {
                    assert!(e.to_string().contains(needle), "{e}");
                    assert!(e.to_string().contains(&name), "{e}");
                }
                (Ok(_), Some(_)) => panic!("{}: expected an error", path.display()),
                (Err(e), None) => panic!("{e}"),
            }
        }
    }
    assert!(read_ok >= 20, "only {read_ok} assimp meshes read");
}

#[test]
fn assimp_known_counts() {
    for (file, triangles) in [
        // Six quads.
        ("OBJ/box.obj", 12),
        ("OBJ/testmixed.obj", 12),
        // Counted from the `f` lines: Σ (n − 2).
        ("OBJ/spider.obj", 1368),
        ("OBJ/regr01.obj", 2710),
        ("OFF/Cube.off", 12),
        ("PLY/cube.ply", 12),
        ("PLY/cube_binary.ply", 12),
        ("PLY/float-color.ply", 1),
    ] {
        let mesh = read(&external(&format!("assimp/{file}")));
        assert_eq!(mesh.triangles.len(), triangles, "{file}");
    }
    let spider = read(&external("assimp/OBJ/spider.obj"));
    // No `vn` lines in spider.obj; the texture-coordinate splits make more
    // vertices than its 762 `v` lines.
    assert!(spider.normals.is_empty() && spider.positions.len() >= 762);
}

#[test]
fn assimp_cube_ascii_and_binary_ply_are_the_same_mesh() {
    // cube.ply's quads fan into exactly the triangles cube_binary.ply stores.
    let ascii = read(&external("assimp/PLY/cube.ply"));
    let binary = read(&external("assimp/PLY/cube_binary.ply"));
    assert_eq!(ascii.positions.len(), 8);
    assert_eq!(ascii, binary);
}

#[test]
fn assimp_wuson_agrees_across_formats() {
    let obj = read(&external("assimp/OBJ/WusonOBJ.obj"));
    let ply = read(&external("assimp/PLY/Wuson.ply"));
    let off = read(&external("assimp/OFF/Wuson.off"));
    // The same 3732 triangles; vertex counts differ with how each format
    // splits vertices at normal and texture seams.
    for mesh in [&obj, &ply, &off] {
        assert_eq!(mesh.triangles.len(), 3732);
    }
    assert_eq!(off.positions.len(), 3205);
    assert_eq!(ply.positions.len(), 11184);
    assert_eq!(ply.normals.len(), ply.positions.len());
    // Same bounding box: the files print six decimals, so they agree to 1e-5.
    let (lo, hi) = bounds(&off);
    for mesh in [&obj, &ply] {
        let (l, h) = bounds(mesh);
        assert!(l.abs_diff_eq(lo, 1e-5) && h.abs_diff_eq(hi, 1e-5));
    }
}

// ----------------------------------------------------------- PLY byte orders

/// A tetrahedron in PLY with every scalar type, a list to skip in the
/// vertex element, a polygon, and an extra element, in the given format.
fn tetra_ply(format: &str) -> Vec<u8> {
    let positions = [
        [0.0f32, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    ];
    let normals = [
        [-1.0f64, -1.0, -1.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    ];
    let faces: [&[i32]; 3] = [&[0, 2, 1], &[0, 1, 3], &[0, 3, 2, 1]];
    let mut out = format!(
        "ply\nformat {format} 1.0\ncomment written by raylab's reader tests\n\
         element vertex 4\nproperty char c\nproperty float x\nproperty uchar u\n\
         property float y\nproperty list ushort short tags\nproperty float z\n\
         property double nx\nproperty double ny\nproperty double nz\nproperty uint label\n\
         element face 3\nproperty int16 flags\nproperty list uint8 int32 vertex_indices\n\
         property float64 quality\n\
         element edge 2\nproperty list uchar uint vertex_pair\nproperty int8 crease\n\
         end_header\n"
    )
    .into_bytes();
    let big = format == "binary_big_endian";
    macro_rules! put {
        ($v:expr) => {
            if format == "ascii" {
                out.extend(format!("{} ", $v).into_bytes());
            } else if big {
                out.extend($v.to_be_bytes());
            } else {
                out.extend($v.to_le_bytes());
            }
        };
    }
    let newline = |out: &mut Vec<u8>| {
        if format == "ascii" {
            out.push(b'\n');
        }
    };
    for (i, (p, n)) in positions.iter().zip(normals).enumerate() {
        put!(-3i8);
        put!(p[0]);
        put!(200u8);
        put!(p[1]);
        put!(2u16);
        put!(-7i16);
        put!(i as i16);
        put!(p[2]);
        put!(n[0]);
        put!(n[1]);
        put!(n[2]);
        put!(4_000_000_000u32);
        newline(&mut out);
    }
    for f in faces {
        put!(-1i16);
        put!(f.len() as u8);
        for &v in f {
            put!(v);
        }
        put!(0.5f64);
        newline(&mut out);
    }
    for pair in [[0u32, 1], [2, 3]] {
        put!(2u8);
        put!(pair[0]);
        put!(pair[1]);
        put!(1i8);
        newline(&mut out);
    }
    out
}

#[test]
fn ply_ascii_little_and_big_endian_decode_alike() {
    let dir = tempfile::tempdir().expect("temporary folder");
    let mut meshes = Vec::new();
    for format in ["ascii", "binary_little_endian", "binary_big_endian"] {
        let path = dir.path().join(format!("tetra_{format}.PLY"));
        std::fs::write(&path, tetra_ply(format)).expect("write test file");
        meshes.push(read(&path));
    }
    let ascii = &meshes[0];
    assert_eq!(ascii.positions[3], Vec3::Z);
    // Two triangles and a quad fanned into two more.
    assert_eq!(
        ascii.triangles,
        vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [0, 2, 1]]
    );
    // (-1, -1, -1) normalised.
    assert!(ascii.normals[0].abs_diff_eq(Vec3::splat(-(1.0f32 / 3.0).sqrt()), 1e-6));
    assert_eq!(&meshes[1], ascii);
    assert_eq!(&meshes[2], ascii);
}

// ----------------------------------------------------------------------- 3DS

#[test]
fn every_assimp_3ds_reads() {
    let files = mesh_files(&external("assimp/3DS"));
    assert!(files.len() >= 9);
    for path in files {
        let mesh = read(&path);
        assert_well_formed(&mesh, &path);
    }
}

#[test]
fn assimp_3ds_cubes() {
    for name in [
        "RotatingCube.3DS",
        "CameraRollAnim.3ds",
        "cube_with_diffuse_texture.3DS",
        "cube_with_specular_texture.3DS",
    ] {
        let mesh = read(&external(&format!("assimp/3DS/{name}")));
        assert_eq!(mesh.triangles.len(), 12, "{name}");
        // Stored with texture seams (26 or 32 vertices), but a cube has
        // eight corners.
        let mut corners: Vec<[u32; 3]> = mesh
            .positions
            .iter()
            .map(|p| p.to_array().map(f32::to_bits))
            .collect();
        corners.sort_unstable();
        corners.dedup();
        assert_eq!(corners.len(), 8, "{name}");
    }
    // Objects are merged: test1.3ds holds nine boxes, cubes_with_alpha five.
    assert_eq!(
        read(&external("assimp/3DS/test1.3ds")).triangles.len(),
        9 * 12
    );
    assert_eq!(
        read(&external("assimp/3DS/cubes_with_alpha.3DS"))
            .triangles
            .len(),
        5 * 12
    );
    assert_eq!(
        read(&external("assimp/3DS/CameraRollAnimWithChildObject.3ds"))
            .triangles
            .len(),
        2 * 12
    );
}

// ------------------------------------------------------------- invalid input

#[test]
fn assimp_invalid_files_are_errors_not_panics() {
    let files = mesh_files(&external("assimp/invalid"));
    assert!(files.len() >= 7, "OutOfMemory.off, malformed*.obj, empty.*");
    for path in files {
        let result = std::panic::catch_unwind(|| read_mesh(&path));
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        match result {
            Ok(Err(e)) => assert!(e.to_string().contains(&name), "{e}"),
            Ok(Ok(_)) => panic!("{}: expected an error", path.display()),
            Err(_) => panic!("{}: the reader panicked", path.display()),
        }
    }
}

/// Read a hand-made broken file, expecting an error that names the file.
fn broken_error(name: &str) -> InputError {
    let path = broken(name);
    let error = read_mesh(&path).expect_err(name);
    assert!(error.to_string().contains(name), "{error}");
    error
}

#[test]
fn broken_files_name_the_place() {
    // (file, place, words the message must contain)
    let cases: [(&str, Place, &[&str]); 12] = [
        // Header 225 bytes + 2 whole vertices (24) + 5 bytes of the third.
        (
            "truncated_binary.ply",
            Place::Byte(249),
            &[
                "truncated",
                "vertex 2",
                "expected 12 bytes",
                "file ends at 254",
            ],
        ),
        (
            "nan_coordinate.ply",
            Place::Line(13),
            &["vertex 2", "non-finite"],
        ),
        (
            "index_out_of_range_be.ply",
            Place::Byte(287),
            &["face 1", "out of range"],
        ),
        // 3·10^9 vertices declared; the 65 bytes of body hold five (the
        // fifth made of the face's bytes), and the sixth is cut short.
        (
            "absurd_count.ply",
            Place::Byte(294),
            &["truncated", "vertex 5"],
        ),
        ("no_end_header.ply", Place::Line(6), &["end_header"]),
        (
            "index_out_of_range.off",
            Place::Line(9),
            &["face 1", "4 out of range"],
        ),
        (
            "absurd_counts.off",
            Place::Line(3),
            &["1000000000000 vertices", "can hold"],
        ),
        ("face_too_small.off", Place::Line(6), &["at least 3"]),
        (
            "index_out_of_range.obj",
            Place::Line(7),
            &["vertex index 5 out of range"],
        ),
        (
            "chunk_past_end.3ds",
            Place::Byte(28),
            &["0x4110", "runs past", "0x4100"],
        ),
        (
            "main_chunk_past_end.3ds",
            Place::Byte(0),
            &["0x4D4D", "end of the file"],
        ),
        (
            "index_out_of_range.3ds",
            Place::Byte(80),
            &["face 0", "index 3 out of range"],
        ),
    ];
    for (name, place, words) in cases {
        let e = broken_error(name);
        assert_eq!(e.place, place, "{e}");
        for w in words {
            assert!(e.message.contains(w), "{e}: missing `{w}`");
        }
    }
}

#[test]
fn empty_files_are_errors() {
    for ext in ["obj", "ply", "off", "3ds"] {
        let e = broken_error(&format!("empty.{ext}"));
        assert_eq!(e.place, Place::File);
        assert_eq!(e.message, "empty file");
    }
}

#[test]
fn missing_file_and_unknown_extension() {
    let e = read_mesh(Path::new("no/such/mesh.off")).unwrap_err();
    assert!(e.message.contains("cannot read"), "{e}");
    let e = read_mesh(Path::new("mesh.gltf")).unwrap_err();
    assert!(
        e.message.contains(".gltf") && e.message.contains(".obj, .ply, .off, .3ds"),
        "{e}"
    );
}

// -------------------------------------------------------------------- fuzzing

const PLY_HEADERS: [&str; 3] = [
    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n",
    "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n",
    "ply\nformat binary_big_endian 1.0\nelement vertex 4000000000\nproperty double x\nproperty double y\nproperty double z\nproperty list uint uint extra\nelement face 9999999999\nproperty list uint int vertex_indices\nend_header\n",
];

fn no_panic(parse: fn(&[u8], &Path) -> Result<MeshData, InputError>, bytes: &[u8]) {
    // Ok or Err are both fine; returning at all is the point.
    let _ = parse(bytes, Path::new("fuzz"));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..600)) {
        for parse in [parse_ply, parse_off, parse_3ds, parse_obj] {
            no_panic(parse, &bytes);
        }
    }

    #[test]
    fn ply_bodies_never_panic(
        header in 0..PLY_HEADERS.len(),
        body in prop::collection::vec(any::<u8>(), 0..300),
    ) {
        no_panic(parse_ply, &[PLY_HEADERS[header].as_bytes(), &body].concat());
    }

    #[test]
    fn off_texts_never_panic(body in "[0-9 .eE+-]{0,8}(\n[0-9 .#naif-]{0,12}){0,12}") {
        no_panic(parse_off, format!("OFF\n{body}").as_bytes());
        no_panic(parse_off, format!("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n{body}").as_bytes());
    }

    #[test]
    fn obj_texts_never_panic(body in "([vfl] [0-9 /.+-]{0,16}\n){0,12}") {
        no_panic(parse_obj, body.as_bytes());
    }

    #[test]
    fn chunk_trees_never_panic(
        lengths in prop::collection::vec(any::<u32>(), 4),
        ids in prop::collection::vec(prop::sample::select(vec![0x4D4Du16, 0x3D3D, 0x4000, 0x4100, 0x4110, 0x4120, 0x4160]), 4),
        tail in prop::collection::vec(any::<u8>(), 0..200),
    ) {
        let mut bytes = Vec::new();
        for (id, length) in ids.iter().zip(&lengths) {
            bytes.extend(id.to_le_bytes());
            // Mostly plausible lengths, sometimes wild ones.
            let length = if length % 4 == 0 { *length } else { length % 256 };
            bytes.extend(length.to_le_bytes());
            if *id == 0x4000 {
                bytes.extend(b"o\0");
            }
        }
        bytes.extend(tail);
        no_panic(parse_3ds, &bytes);
    }
}
