//! A scene as the shader reads it: one array of 32-bit words holding every
//! section (nodes, primitive slots, primitives, meshes' shading normals,
//! materials, lights, the Halton table), and the uniform [`ShaderParams`] with
//! the camera, the settings and each section's word offset.
//!
//! The primitives are the accelerator's own leaf order: slot i of the GPU's
//! arrays is the i-th primitive of the tree's index array, then come the
//! unbounded ones (planes), so a leaf's run of slots and the brute-force
//! loop over the planes are both contiguous ranges. Records:
//! - binary node (12 words): the volume (box: min, ·, max, ·; sphere:
//!   centre, radius; ellipsoid: centre, ·, 1/radii, ·), first, count,
//!   2 unused (`bvh::Node`);
//! - 4-wide node (32 words): min x, y, z and max x, y, z of the four
//!   children (4 lanes each), `first[4]`, `count[4]`, unused lanes' first and
//!   count set to `u32::MAX` (`bvh::node::Node4`);
//! - slot: its `PrimRef`, and separately its scene primitive index;
//! - triangle (11), sphere (4), ellipsoid (12), plane (6): the `#[repr(C)]`
//!   arrays of `shape::arrays` byte for byte;
//! - mesh (4): first face, first normal, whether it has normals, unused;
//!   face (3 normal indices); normal (3);
//! - material (32 words, per object): see `shader/whitted.wgsl`;
//! - point light (8): position, inverse-square flag, radiance, unused.

use crate::error::GpuError;
use raylab::accel::bvh::volume::{BoundingVolume, QUADRIC_MARGIN};
use raylab::accel::bvh::{BoundingEllipsoid, BoundingSphere, Bvh};
use raylab::accel::Accelerator;
use raylab::light::Falloff;
use raylab::material::Texture;
use raylab::math::{Aabb, SLAB_EXIT_SCALE};
use raylab::sampler::{halton_point, Sampler};
use raylab::scene::Scene;
use raylab::shape::{PrimArrays, OFFSET_SCALE};

/// The uniform block of `shader/common.wgsl` (its `struct Params`), field
/// for field (256 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ShaderParams {
    pub eye: [f32; 3],
    pub near: f32,
    pub u: [f32; 3],
    pub half_width: f32,
    pub v: [f32; 3],
    pub half_height: f32,
    pub n: [f32; 3],
    pub max_distance: f32,
    pub background: [f32; 3],
    pub min_weight: f32,
    pub ambient: [f32; 3],
    pub inf: f32,
    pub root_min: [f32; 3],
    pub has_root: u32,
    pub root_max: [f32; 3],
    pub root_first: u32,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub sampler: u32,
    pub sampler_k: u32,
    pub seed_lo: u32,
    pub seed_hi: u32,
    pub row_offset: u32,
    pub root_count: u32,
    pub n_accel: u32,
    pub n_unbounded: u32,
    pub n_lights: u32,
    pub o_nodes: u32,
    pub o_refs: u32,
    pub o_ids: u32,
    pub o_tris: u32,
    pub o_spheres: u32,
    pub o_ellipsoids: u32,
    pub o_planes: u32,
    pub o_prim_object: u32,
    pub o_meshes: u32,
    pub o_faces: u32,
    pub o_normals: u32,
    pub o_materials: u32,
    pub o_lights: u32,
    pub o_halton: u32,
    pub slab_exit_scale: f32,
    pub offset_scale: f32,
    pub quadric_margin: f32,
    pub rows: u32,
    pub sample_first: u32,
    pub sample_count: u32,
}

const _: () = assert!(std::mem::size_of::<ShaderParams>() == 256);

/// Which traversal the shader compiles in: `ACCEL` and `VOLUME`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Kernel {
    /// 0 brute force, 1 binary BVH, 2 four-wide BVH.
    pub accel: u32,
    /// Binary BVH: 0 box, 1 sphere, 2 ellipsoid.
    pub volume: u32,
}

/// The scene in words, with its parameters and kernel.
pub struct PackedScene {
    pub words: Vec<u32>,
    pub params: ShaderParams,
    pub kernel: Kernel,
}

/// Deepest `max_depth` the GPU takes: its pending-ray and medium stacks
/// are sized by the depth limit, in each invocation's private memory.
pub const GPU_MAX_DEPTH: u32 = 32;

fn push_f32s(words: &mut Vec<u32>, v: &[f32]) {
    words.extend(v.iter().map(|x| x.to_bits()));
}

/// Append a section, returning its word offset.
fn section(words: &mut Vec<u32>, data: &[u32]) -> u32 {
    let at = words.len() as u32;
    words.extend_from_slice(data);
    at
}

/// Binary nodes as 12-word records.
fn binary_nodes<V: BoundingVolume>(bvh: &Bvh<V>, volume: impl Fn(&V) -> [f32; 8]) -> Vec<u32> {
    let mut w = Vec::with_capacity(bvh.nodes().len() * 12);
    for n in bvh.nodes() {
        push_f32s(&mut w, &volume(&n.volume));
        w.extend([n.first, n.count, 0, 0]);
    }
    w
}

/// Pack `scene` for the shader. Fails for what the GPU port does not do:
/// Embree's tree, samplers that are not pure functions of the sample
/// index, filters wider than the box, depth limits above
/// [`GPU_MAX_DEPTH`].
pub fn pack(scene: &Scene) -> Result<PackedScene, GpuError> {
    let set = &scene.settings;
    if set.max_depth > GPU_MAX_DEPTH {
        return Err(GpuError::MaxDepth {
            max_depth: set.max_depth,
            limit: GPU_MAX_DEPTH,
        });
    }
    if set.filter != raylab::film::Filter::Box {
        return Err(GpuError::Filter {
            filter: set.filter.name().to_string(),
        });
    }
    let (sampler, sampler_k) = match set.sampler {
        Sampler::Centre => (0, 1),
        Sampler::OrderedGrid { k } => (1, k),
        Sampler::RotatedGrid => (2, 1),
        Sampler::Jittered { k } => (3, k),
        Sampler::Random { n } => (4, n),
        Sampler::Halton { n } => (5, n),
        Sampler::Sobol { n } => (6, n),
        Sampler::Adaptive { .. } => return Err(GpuError::AdaptiveSampler),
    };

    let mut words = Vec::new();
    let mut p = ShaderParams {
        inf: f32::INFINITY,
        slab_exit_scale: SLAB_EXIT_SCALE,
        offset_scale: OFFSET_SCALE,
        quadric_margin: QUADRIC_MARGIN,
        ..ShaderParams::default()
    };

    // The tree and the slot order it implies.
    let (kernel, nodes, mut slots): (Kernel, Vec<u32>, Vec<u32>) = match &scene.accel {
        Accelerator::Brute(b) => (
            Kernel {
                accel: 0,
                volume: 0,
            },
            Vec::new(),
            b.prims.clone(),
        ),
        Accelerator::BvhAabb(bvh, _) => {
            let w = binary_nodes(bvh, |b: &Aabb| {
                [
                    b.min.x, b.min.y, b.min.z, 0.0, b.max.x, b.max.y, b.max.z, 0.0,
                ]
            });
            (
                Kernel {
                    accel: 1,
                    volume: 0,
                },
                w,
                bvh.indices().to_vec(),
            )
        }
        Accelerator::BvhSphere(bvh, _) => {
            let w = binary_nodes(bvh, |s: &BoundingSphere| {
                let c = s.centre;
                [c.x, c.y, c.z, s.radius, 0.0, 0.0, 0.0, 0.0]
            });
            (
                Kernel {
                    accel: 1,
                    volume: 1,
                },
                w,
                bvh.indices().to_vec(),
            )
        }
        Accelerator::BvhEllipsoid(bvh, _) => {
            let w = binary_nodes(bvh, |e: &BoundingEllipsoid| {
                let (c, r) = (e.centre, e.inv_radii);
                [c.x, c.y, c.z, 0.0, r.x, r.y, r.z, 0.0]
            });
            (
                Kernel {
                    accel: 1,
                    volume: 2,
                },
                w,
                bvh.indices().to_vec(),
            )
        }
        Accelerator::Bvh4(b) => {
            let mut w = Vec::with_capacity(b.nodes().len() * 32);
            for n in b.nodes() {
                for planes in [&n.min, &n.max] {
                    for axis in planes {
                        push_f32s(&mut w, axis);
                    }
                }
                // A leaf's `first` names its packets on the CPU; the shader
                // reads slot runs.
                let first = |i: usize| match n.count[i] {
                    0 | u32::MAX => n.first[i],
                    c => b.leaf_slots(n.first[i], c).start,
                };
                w.extend((0..4).map(first));
                w.extend_from_slice(&n.count);
            }
            if let Some(r) = b.root_box() {
                p.root_min = r.min.to_array();
                p.root_max = r.max.to_array();
                (p.root_first, p.root_count) = match b.root() {
                    (f, 0) => (f, 0),
                    (f, c) => (b.leaf_slots(f, c).start, c),
                };
                p.has_root = 1;
            }
            (
                Kernel {
                    accel: 2,
                    volume: 0,
                },
                w,
                b.indices().to_vec(),
            )
        }
        Accelerator::Bvh8(_) => return Err(GpuError::Bvh8),
        // Embree's tree lives inside Embree, obvhs's inside obvhs (each with
        // its feature of the core crate): neither can be uploaded.
        other => {
            return Err(GpuError::ForeignTree {
                accel: other.kind().to_string(),
            })
        }
    };
    if kernel.accel == 1 {
        p.has_root = u32::from(!nodes.is_empty());
    }
    p.n_accel = slots.len() as u32;
    p.n_unbounded = scene.unbounded.len() as u32;
    slots.extend_from_slice(&scene.unbounded);
    let arrays = PrimArrays::new(slots.iter().map(|&i| &scene.prims[i as usize]));

    p.o_nodes = section(&mut words, &nodes);
    p.o_refs = section(&mut words, bytemuck::cast_slice(&arrays.refs));
    p.o_ids = section(&mut words, &slots);
    p.o_tris = section(&mut words, bytemuck::cast_slice(&arrays.triangles));
    p.o_spheres = section(&mut words, bytemuck::cast_slice(&arrays.spheres));
    p.o_ellipsoids = section(&mut words, bytemuck::cast_slice(&arrays.ellipsoids));
    p.o_planes = section(&mut words, bytemuck::cast_slice(&arrays.planes));
    let objects: Vec<u32> = scene.prims.iter().map(|q| q.object).collect();
    p.o_prim_object = section(&mut words, &objects);

    // Shading normals of the meshes.
    let (mut meshes, mut faces, mut normals) = (Vec::new(), Vec::new(), Vec::new());
    for m in &scene.meshes {
        meshes.extend([
            (faces.len() / 3) as u32,
            (normals.len() / 3) as u32,
            u32::from(!m.normals.is_empty()),
            0,
        ]);
        // Faces are looked up only for meshes with normals.
        if !m.normals.is_empty() {
            faces.extend(m.triangles.iter().flatten());
            for n in &m.normals {
                push_f32s(&mut normals, &n.to_array());
            }
        }
    }
    p.o_meshes = section(&mut words, &meshes);
    p.o_faces = section(&mut words, &faces);
    p.o_normals = section(&mut words, &normals);

    let mut materials = Vec::with_capacity(scene.objects.len() * 32);
    for o in &scene.objects {
        materials.extend(material_words(&scene.materials[o.material as usize]));
    }
    p.o_materials = section(&mut words, &materials);

    let mut lights = Vec::with_capacity(scene.lights.len() * 8);
    for l in &scene.lights {
        push_f32s(&mut lights, &l.position.to_array());
        lights.push(u32::from(l.falloff == Falloff::InverseSquare));
        push_f32s(&mut lights, &l.radiance.to_array());
        lights.push(0);
    }
    p.o_lights = section(&mut words, &lights);

    let mut halton = Vec::new();
    if let Sampler::Halton { n } = set.sampler {
        for i in 0..n {
            push_f32s(&mut halton, &halton_point(i).to_array());
        }
    }
    p.o_halton = section(&mut words, &halton);
    // A binding may not be empty.
    if words.is_empty() {
        words.push(0);
    }

    let cam = &scene.camera;
    p.eye = cam.eye.to_array();
    p.u = cam.u.to_array();
    p.v = cam.v.to_array();
    p.n = cam.n.to_array();
    p.near = cam.near;
    p.half_width = cam.half_width;
    p.half_height = cam.half_height;
    p.width = cam.width;
    p.height = cam.height;
    p.max_distance = set.max_distance;
    p.background = set.background.to_array();
    p.ambient = set.ambient.to_array();
    p.min_weight = set.min_weight;
    p.spp = set.sampler.spp();
    p.sampler = sampler;
    p.sampler_k = sampler_k;
    p.seed_lo = set.seed as u32;
    p.seed_hi = (set.seed >> 32) as u32;
    p.n_lights = scene.lights.len() as u32;
    Ok(PackedScene {
        words,
        params: p,
        kernel,
    })
}

/// A material as the shader's 32-word record.
fn material_words(m: &raylab::material::Material) -> [u32; 32] {
    let mut f = [0.0f32; 32];
    f[0..3].copy_from_slice(&m.color.to_array());
    f[3] = m.ambient;
    f[4] = m.diffuse;
    f[5] = m.specular;
    f[6] = m.shininess;
    f[7..10].copy_from_slice(&m.specular_color.to_array());
    f[10] = m.reflectivity;
    f[11] = m.transparency;
    f[12] = m.ior;
    f[13..16].copy_from_slice(&m.emission.to_array());
    let mut kind = 0u32;
    if let Some(t) = &m.texture {
        let (k, param, color, origin, u, v) = match *t {
            Texture::Checker {
                size,
                color,
                origin,
                u_axis,
                v_axis,
            } => (1, size, color, origin, u_axis, v_axis),
            Texture::ZonePlate {
                k,
                color,
                origin,
                u_axis,
                v_axis,
            } => (2, k, color, origin, u_axis, v_axis),
        };
        kind = k;
        f[17] = param;
        f[18..21].copy_from_slice(&color.to_array());
        f[21..24].copy_from_slice(&origin.to_array());
        f[24..27].copy_from_slice(&u.to_array());
        f[27..30].copy_from_slice(&v.to_array());
    }
    let mut w = f.map(f32::to_bits);
    w[16] = kind;
    w
}
