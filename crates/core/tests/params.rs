//! The scene's parameter table (`raylab::scene::param`) and the one scene
//! builder (`raylab::scene::build`): every parameter's name parses back
//! into its id, reads and writes its value, and a description changed
//! through the table builds the same scene as the scene file with the new
//! value written into its text; a mesh's vertices are parameters, and a
//! derivative with respect to all of them adds up to the one with respect
//! to the mesh's translation.

use raylab::diff::{self, GradientRender, Visibility};
use raylab::integrator::IntegratorKind;
use raylab::io::scene_file::{Overrides, SceneSource};
use raylab::scene::param::{MeshField, ParamId, Shape, Target};
use raylab::scene::Scene;
use std::path::{Path, PathBuf};

/// A scene with every kind of entity and field (a textured material, a
/// per-axis mesh scale, an aspect and a `fit`, so that the optional fields
/// are parameters), in a folder beside the repository's cube mesh.
fn every_entity() -> (PathBuf, String) {
    let text = r#"
[image]
width = 20
height = 15
[camera]
eye = [0.3, 1.2, 6.0]
look_at = [0.0, 0.4, 0.0]
up = [0.0, 1.0, 0.1]
fov = 45.0
aspect = 1.3
near = 1.2
[render]
background = [0.1, 0.15, 0.2]
ambient = [0.2, 0.2, 0.2]
max_depth = 3
sampler = "jitter:2"
[materials.white]
color = [0.8, 0.8, 0.8]
diffuse = 0.9
[materials.glass]
transparency = 0.9
ior = 1.5
[materials.lamp]
emission = [4.0, 3.8, 3.5]
[[sphere]]
center = [-1.2, 0.6, 0.0]
radius = 0.6
material = "glass"
[[sphere]]
center = [0.0, 3.0, 0.5]
radius = 0.3
material = "lamp"
[[ellipsoid]]
center = [1.2, 0.5, 0.2]
radii = [0.7, 0.4, 0.5]
rotate = [10.0, 30.0, -20.0]
material = "white"
[[plane]]
point = [0.0, -0.1, 0.0]
normal = [0.05, 1.0, 0.02]
material = "white"
[[triangle]]
vertices = [[-2.5, -0.1, -2.0], [2.5, -0.1, -2.0], [0.0, 2.5, -2.2]]
material = "white"
[[mesh]]
file = "data/meshes/cube.obj"
material = "white"
fit = 0.8
scale = [1.0, 1.5, 0.8]
rotate = [0.0, 35.0, 10.0]
translate = [0.2, 0.3, 1.3]
normals = "computed"
[[mesh]]
procedural = { kind = "icosphere", level = 1 }
material = "white"
scale = 0.4
translate = [-0.2, 1.4, 1.0]
[[light]]
position = [2.0, 4.0, 3.0]
color = [1.0, 0.9, 0.8]
intensity = 0.9
"#;
    (raylab_testkit::repo().join("scene.toml"), text.to_string())
}

fn source(path: &Path, text: &str) -> SceneSource {
    SceneSource::parse(text, path, &Overrides::default()).unwrap()
}

/// Every number of the scene's primitives, lights and camera, as bits.
fn fingerprint(scene: &Scene) -> Vec<u32> {
    let mut out = Vec::new();
    for p in &scene.prims {
        out.extend(format!("{:?}", p.shape).bytes().map(u32::from));
    }
    for l in &scene.lights {
        out.extend(l.position.to_array().map(f32::to_bits));
        out.extend(l.radiance.to_array().map(f32::to_bits));
    }
    let c = &scene.camera;
    for v in [c.eye, c.u, c.v, c.n] {
        out.extend(v.to_array().map(f32::to_bits));
    }
    out.extend([c.near, c.half_height, c.half_width].map(f32::to_bits));
    for m in &scene.materials {
        out.extend(format!("{m:?}").bytes().map(u32::from));
    }
    for m in &scene.meshes {
        for n in &m.normals {
            out.extend(n.to_array().map(f32::to_bits));
        }
    }
    out.extend(
        [scene.settings.background, scene.settings.ambient]
            .iter()
            .flat_map(|c| c.to_array().map(f32::to_bits)),
    );
    out
}

/// Each field: its name parses back into the same selection, each
/// component's name into its id; a new value set through the table
/// builds the same scene as the file with that value written into it.
#[test]
fn every_parameter_round_trips_through_names_values_and_text() {
    let (path, text) = every_entity();
    let src = source(&path, &text);
    let desc = &src.description;
    let all = desc.parameters();
    // Camera 6, render 2, 3 materials × 10, 2 spheres × 2, ellipsoid 3,
    // plane 2, triangle 1, meshes 5 + 4 (the icosphere has no `fit`),
    // light 3.
    assert_eq!(all.len(), 6 + 2 + 30 + 4 + 3 + 2 + 1 + 9 + 3);
    for sel in &all {
        let field = desc.entity_name(sel.target.entity()) + "." + sel.target.key();
        assert_eq!(desc.select(&field).unwrap(), *sel, "{field}");
        for id in sel.ids() {
            let name = desc.param_name(id);
            let again = desc.select(&name).unwrap();
            assert_eq!(again.ids().collect::<Vec<_>>(), vec![id], "{name}");
        }
        if matches!(sel.target, Target::Mesh(_, MeshField::Vertices)) {
            continue; // in the mesh file, not the scene file (below)
        }
        // A new value of the field's last component, set through the table
        // and written into the text.
        let id = sel.ids().last().unwrap();
        let v = desc.value(id);
        let new = if v == 0.0 { 0.125 } else { v * 1.0625 };
        let mut moved = desc.clone();
        moved.set_value(id, new);
        assert_eq!(moved.value(id), new);
        let built = src.build_from(&moved).unwrap();
        let written = src.text_with(&moved, &[sel.target]).unwrap();
        let reread = source(&path, &written).build().unwrap();
        assert_eq!(
            fingerprint(&built),
            fingerprint(&reread),
            "{}",
            desc.param_name(id)
        );
        assert_ne!(
            fingerprint(&built),
            fingerprint(&src.build().unwrap()),
            "{} moved nothing",
            desc.param_name(id)
        );
    }
}

/// A mesh's vertices: all of them, one, one coordinate, a range; their
/// values are the mesh's own positions, and writing one copies the mesh
/// for the description that changed (the original keeps its own).
#[test]
fn mesh_vertices_are_parameters_in_bulk() {
    let (path, text) = every_entity();
    let src = source(&path, &text);
    let desc = &src.description;
    let n = desc.meshes[0].data.positions.len() as u32;
    let all = desc.select("mesh[0].vertices").unwrap();
    assert_eq!(all.components, 0..3 * n);
    assert_eq!(desc.shape_of(all.target), Shape::Points);
    assert_eq!(desc.select("mesh[0].vertices[2]").unwrap().components, 6..9);
    assert_eq!(
        desc.select("mesh[0].vertices[2][1]").unwrap().components,
        7..8
    );
    assert_eq!(
        desc.select("mesh[0].vertices[1..3]").unwrap().components,
        3..9
    );
    for bad in [
        "mesh[0].vertices[99]",
        "mesh[0].vertices[0][3]",
        "mesh[0].vertices[3..1]",
    ] {
        let e = desc.select(bad).unwrap_err().to_string();
        assert!(e.contains("[vertex][axis]"), "{bad}: {e}");
    }
    let id = ParamId {
        target: all.target,
        component: 7,
    };
    assert_eq!(desc.value(id), desc.meshes[0].data.positions[2].y);
    let mut moved = desc.clone();
    moved.set_value(id, 5.0);
    assert_eq!(moved.meshes[0].data.positions[2].y, 5.0);
    assert_ne!(desc.meshes[0].data.positions[2].y, 5.0);
    assert!(src.text_with(&moved, &[all.target]).is_err());
}

/// With the identity transform, moving the mesh by its translation is
/// moving every vertex: ∂I/∂t_x = Σ_k ∂I/∂v_k,x, pixel by pixel (to the
/// rounding of adding up 8 derivatives: 1e-4 of the largest |∂I/∂t_x|).
/// Interior and boundary terms alike, since both are linear in the
/// parameters' velocities.
#[test]
fn all_vertices_move_as_the_translation_does() {
    let text = r#"
[image]
width = 16
height = 12
[camera]
eye = [1.5, 1.5, 4.0]
look_at = [0.0, 0.0, 0.0]
fov = 40.0
[render]
sampler = "jitter:2"
ambient = [0.1, 0.1, 0.1]
[materials.m]
color = [0.8, 0.5, 0.3]
diffuse = 0.9
[[mesh]]
file = "data/meshes/cube.obj"
material = "m"
[[light]]
position = [3.0, 4.0, 2.0]
"#;
    let path = raylab_testkit::repo().join("t.toml");
    let src = source(&path, text);
    let desc = &src.description;
    let scene = src.build().unwrap();
    let n = desc.meshes[0].data.positions.len();
    let mut names = vec!["mesh[0].translate[0]".to_string()];
    names.extend((0..n).map(|k| format!("mesh[0].vertices[{k}][0]")));
    let p = diff::resolve_all(&names, desc).unwrap();
    for visibility in [Visibility::Interior, Visibility::Full] {
        let g = diff::render_gradients(&GradientRender {
            scene: &scene,
            desc,
            params: &p,
            integrator: IntegratorKind::Whitted,
            visibility,
            threads: None,
        })
        .unwrap();
        let t = &g.planes.mean[0];
        let scale = t.iter().fold(0.0f32, |m, x| m.max(x.abs()));
        assert!(scale > 0.0);
        for (j, &tx) in t.iter().enumerate() {
            let sum: f32 = (1..=n).map(|k| g.planes.mean[k][j]).sum();
            assert!(
                (tx - sum).abs() <= 1e-4 * scale,
                "{visibility:?}, element {j}: {tx} against {sum}"
            );
        }
    }
}
