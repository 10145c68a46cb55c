//! Parameter values: where each field's numbers live in a
//! [`SceneDescription`], read and written as flat `f32` slices (one
//! table, `field_numbers!`, for both).

use super::{
    CameraField, EllipsoidField, LightField, MaterialField, MeshField, ParamId, PlaneField,
    RenderField, SphereField, Target, TriangleField,
};
use crate::math::Vec3;
use crate::scene::description::Scale;
use crate::scene::SceneDescription;
use crate::shape::MeshData;
use std::sync::Arc;

/// Where each field's numbers live in a description, written once for
/// shared and mutable access ([`SceneDescription::numbers`] and
/// [`SceneDescription::numbers_mut`]): `$($mut)?` is empty or `mut`.
macro_rules! field_numbers {
    ($desc:expr, $target:expr $(, $mut:tt)?) => {{
        let d = $desc;
        match $target {
            Target::Camera(f) => {
                let c = & $($mut)? d.camera;
                match f {
                    CameraField::Eye => (& $($mut)? c.eye).floats(),
                    CameraField::LookAt => (& $($mut)? c.look_at).floats(),
                    CameraField::Up => (& $($mut)? c.up).floats(),
                    CameraField::Fov => (& $($mut)? c.fov).floats(),
                    CameraField::Near => (& $($mut)? c.near).floats(),
                    CameraField::Aspect => (& $($mut)? c.aspect).floats(),
                }
            }
            Target::Render(f) => {
                let r = & $($mut)? d.settings;
                match f {
                    RenderField::Background => (& $($mut)? r.background).floats(),
                    RenderField::Ambient => (& $($mut)? r.ambient).floats(),
                }
            }
            Target::Material(i, f) => {
                let m = & $($mut)? d.materials[i as usize].material;
                match f {
                    MaterialField::Color => (& $($mut)? m.color).floats(),
                    MaterialField::Ambient => (& $($mut)? m.ambient).floats(),
                    MaterialField::Diffuse => (& $($mut)? m.diffuse).floats(),
                    MaterialField::Specular => (& $($mut)? m.specular).floats(),
                    MaterialField::Shininess => (& $($mut)? m.shininess).floats(),
                    MaterialField::SpecularColor => (& $($mut)? m.specular_color).floats(),
                    MaterialField::Reflectivity => (& $($mut)? m.reflectivity).floats(),
                    MaterialField::Transparency => (& $($mut)? m.transparency).floats(),
                    MaterialField::Ior => (& $($mut)? m.ior).floats(),
                    MaterialField::Emission => (& $($mut)? m.emission).floats(),
                }
            }
            Target::Sphere(i, f) => {
                let s = & $($mut)? d.spheres[i as usize];
                match f {
                    SphereField::Center => (& $($mut)? s.center).floats(),
                    SphereField::Radius => (& $($mut)? s.radius).floats(),
                }
            }
            Target::Ellipsoid(i, f) => {
                let e = & $($mut)? d.ellipsoids[i as usize];
                match f {
                    EllipsoidField::Center => (& $($mut)? e.center).floats(),
                    EllipsoidField::Radii => (& $($mut)? e.radii).floats(),
                    EllipsoidField::Rotate => (& $($mut)? e.rotate).floats(),
                }
            }
            Target::Plane(i, f) => {
                let p = & $($mut)? d.planes[i as usize];
                match f {
                    PlaneField::Point => (& $($mut)? p.point).floats(),
                    PlaneField::Normal => (& $($mut)? p.normal).floats(),
                }
            }
            Target::Triangle(i, TriangleField::Vertices) => {
                (& $($mut)? d.triangles[i as usize].vertices).floats()
            }
            Target::Mesh(i, f) => {
                let m = & $($mut)? d.meshes[i as usize];
                match f {
                    MeshField::Translate => (& $($mut)? m.translate).floats(),
                    MeshField::Rotate => (& $($mut)? m.rotate).floats(),
                    MeshField::Scale => (& $($mut)? m.scale).floats(),
                    MeshField::Fit => (& $($mut)? m.fit).floats(),
                    MeshField::Vertices => (& $($mut)? m.data).floats(),
                }
            }
            Target::Light(i, f) => {
                let l = & $($mut)? d.lights[i as usize];
                match f {
                    LightField::Position => (& $($mut)? l.position).floats(),
                    LightField::Color => (& $($mut)? l.color).floats(),
                    LightField::Intensity => (& $($mut)? l.intensity).floats(),
                }
            }
        }
    }};
}

/// A field's storage as a slice of `f32`: shared or mutable, so that
/// [`field_numbers`] is written once.
trait Floats {
    type Slice;
    fn floats(self) -> Self::Slice;
}

impl<'a> Floats for &'a f32 {
    type Slice = &'a [f32];
    fn floats(self) -> &'a [f32] {
        std::slice::from_ref(self)
    }
}

impl<'a> Floats for &'a mut f32 {
    type Slice = &'a mut [f32];
    fn floats(self) -> &'a mut [f32] {
        std::slice::from_mut(self)
    }
}

impl<'a> Floats for &'a Vec3 {
    type Slice = &'a [f32];
    fn floats(self) -> &'a [f32] {
        AsRef::<[f32; 3]>::as_ref(self)
    }
}

impl<'a> Floats for &'a mut Vec3 {
    type Slice = &'a mut [f32];
    fn floats(self) -> &'a mut [f32] {
        AsMut::<[f32; 3]>::as_mut(self)
    }
}

impl<'a> Floats for &'a [Vec3; 3] {
    type Slice = &'a [f32];
    fn floats(self) -> &'a [f32] {
        bytemuck::cast_slice(self)
    }
}

impl<'a> Floats for &'a mut [Vec3; 3] {
    type Slice = &'a mut [f32];
    fn floats(self) -> &'a mut [f32] {
        bytemuck::cast_slice_mut(self)
    }
}

/// An optional field is a parameter only where it is set
/// ([`SceneDescription::len_of`] refuses the others).
impl<'a> Floats for &'a Option<f32> {
    type Slice = &'a [f32];
    fn floats(self) -> &'a [f32] {
        self.as_ref()
            .expect("a parameter of an unset optional field")
            .floats()
    }
}

impl<'a> Floats for &'a mut Option<f32> {
    type Slice = &'a mut [f32];
    fn floats(self) -> &'a mut [f32] {
        self.as_mut()
            .expect("a parameter of an unset optional field")
            .floats()
    }
}

impl<'a> Floats for &'a Scale {
    type Slice = &'a [f32];
    fn floats(self) -> &'a [f32] {
        match self {
            Scale::Uniform(s) => s.floats(),
            Scale::PerAxis(v) => v.floats(),
        }
    }
}

impl<'a> Floats for &'a mut Scale {
    type Slice = &'a mut [f32];
    fn floats(self) -> &'a mut [f32] {
        match self {
            Scale::Uniform(s) => s.floats(),
            Scale::PerAxis(v) => v.floats(),
        }
    }
}

/// A mesh's vertex positions (copied first, when written, if another
/// description shares them).
impl<'a> Floats for &'a Arc<MeshData> {
    type Slice = &'a [f32];
    fn floats(self) -> &'a [f32] {
        bytemuck::cast_slice(&self.positions)
    }
}

impl<'a> Floats for &'a mut Arc<MeshData> {
    type Slice = &'a mut [f32];
    fn floats(self) -> &'a mut [f32] {
        bytemuck::cast_slice_mut(&mut Arc::make_mut(self).positions)
    }
}

impl SceneDescription {
    /// The value of one parameter.
    ///
    /// # Panics
    /// If `id` does not address a number of this description (ids come
    /// from [`SceneDescription::select`] on it).
    pub fn value(&self, id: ParamId) -> f32 {
        self.numbers(id.target)[id.component as usize]
    }

    /// All components of a field, flattened (vectors x, y, z; points
    /// vertex by vertex).
    pub fn values(&self, target: Target) -> Vec<f32> {
        self.numbers(target).to_vec()
    }

    /// Set one parameter (no range check: [`SceneDescription::check`]
    /// says whether the result is a valid scene).
    ///
    /// # Panics
    /// As [`SceneDescription::value`].
    pub fn set_value(&mut self, id: ParamId, v: f32) {
        self.numbers_mut(id.target)[id.component as usize] = v;
    }

    /// The field's numbers, flattened.
    fn numbers(&self, target: Target) -> &[f32] {
        field_numbers!(self, target)
    }

    /// The field's numbers, flattened, to write (a mesh's vertices are
    /// copied first if another description shares them).
    fn numbers_mut(&mut self, target: Target) -> &mut [f32] {
        field_numbers!(self, target, mut)
    }
}
