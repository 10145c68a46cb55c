//! Instrumentation: what a render costs, counted without slowing it down.
//!
//! Hot paths (traversal, primitive tests, the integrators) are generic over a
//! [`Stats`] sink. [`NoStats`] has empty `#[inline(always)]` methods, so the
//! counting code compiles away; [`Counters`] holds plain `u64` fields, one
//! value per thread, merged after the parallel loop (no atomics, no locks).

use std::ops::AddAssign;

/// Which kind of ray was traced: what spawned it. The renderers count
/// their rays by kind, and the fixed ray workloads of the accelerator
/// benchmarks ([`crate::workload`]) are sets of rays of these kinds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RayKind {
    /// Through a pixel from the camera ("primary" rays).
    Camera,
    /// Towards a light, asking only whether anything is in the way.
    Shadow,
    /// Whitted's mirror reflection.
    Reflection,
    /// Whitted's refraction.
    Refraction,
    /// A path tracer's bounce: a cosine-sampled diffuse direction.
    Path,
    /// A probe ray with no place in a render: from a random point around
    /// the scene through a random point of its bounds (the least coherent
    /// rays, for accelerator benchmarks).
    Random,
}

impl RayKind {
    /// Every kind.
    pub const ALL: [RayKind; 6] = [
        RayKind::Camera,
        RayKind::Shadow,
        RayKind::Reflection,
        RayKind::Refraction,
        RayKind::Path,
        RayKind::Random,
    ];

    /// The kind's name in tables, CSV columns and parameters.
    pub fn name(self) -> &'static str {
        match self {
            RayKind::Camera => "camera",
            RayKind::Shadow => "shadow",
            RayKind::Reflection => "reflection",
            RayKind::Refraction => "refraction",
            RayKind::Path => "path",
            RayKind::Random => "random",
        }
    }

    /// Shadow rays ask whether anything is hit (any-hit query); the others
    /// ask for the closest hit.
    pub fn any_hit(self) -> bool {
        self == RayKind::Shadow
    }
}

impl std::fmt::Display for RayKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for RayKind {
    type Err = crate::ParseError;
    fn from_str(s: &str) -> Result<Self, crate::ParseError> {
        RayKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| crate::ParseError::Unknown {
                what: "ray kind",
                given: s.to_string(),
                expected: "camera, shadow, reflection, refraction, path or random".into(),
            })
    }
}

/// A sink for events on the hot path. Every method defaults to doing
/// nothing so that new events can be added without touching every sink.
pub trait Stats {
    /// Whether this sink records anything (lets callers skip work that only
    /// feeds statistics, such as per-pixel cost buffers).
    const ENABLED: bool;
    fn ray(&mut self, _kind: RayKind) {}
    fn node_visit(&mut self) {}
    fn box_test(&mut self) {}
    /// `n` box tests at once (a wide node's children).
    fn boxes_tested(&mut self, n: u32) {
        for _ in 0..n {
            self.box_test();
        }
    }
    fn bounding_sphere_test(&mut self) {}
    fn bounding_ellipsoid_test(&mut self) {}
    fn triangle_test(&mut self) {}
    /// `n` triangle tests at once (a packet's lanes).
    fn triangles_tested(&mut self, n: u32) {
        for _ in 0..n {
            self.triangle_test();
        }
    }
    fn sphere_test(&mut self) {}
    fn ellipsoid_test(&mut self) {}
    fn plane_test(&mut self) {}
    fn primitive_hit(&mut self) {}
}

/// What the render loop needs of a sink: one instance per row or pixel
/// (`Default`, `Clone`), shared read-only across threads (`Send + Sync`)
/// and merged afterwards (`+=`). Every sink here is one.
pub trait RenderStats: Stats + Default + AddAssign + Clone + Send + Sync {}

impl<T: Stats + Default + AddAssign + Clone + Send + Sync> RenderStats for T {}

/// The sink that records nothing and costs nothing.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoStats;

impl Stats for NoStats {
    const ENABLED: bool = false;
}

/// Event counts. Plain fields: one instance per thread (or per pixel), summed
/// afterwards with `+=`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct Counters {
    pub camera_rays: u64,
    pub shadow_rays: u64,
    pub reflection_rays: u64,
    pub refraction_rays: u64,
    pub path_rays: u64,
    pub random_rays: u64,
    pub nodes_visited: u64,
    pub box_tests: u64,
    pub bounding_sphere_tests: u64,
    pub bounding_ellipsoid_tests: u64,
    pub triangle_tests: u64,
    pub sphere_tests: u64,
    pub ellipsoid_tests: u64,
    pub plane_tests: u64,
    pub primitive_hits: u64,
}

impl Counters {
    /// All rays of every kind.
    pub fn rays(&self) -> u64 {
        self.camera_rays
            + self.shadow_rays
            + self.reflection_rays
            + self.refraction_rays
            + self.path_rays
            + self.random_rays
    }

    /// Bounding-volume tests of every kind.
    pub fn bounding_volume_tests(&self) -> u64 {
        self.box_tests + self.bounding_sphere_tests + self.bounding_ellipsoid_tests
    }

    /// Ray–primitive tests of every kind.
    pub fn primitive_tests(&self) -> u64 {
        self.triangle_tests + self.sphere_tests + self.ellipsoid_tests + self.plane_tests
    }

    /// Named values in a fixed order, for tables and CSV columns.
    pub fn named(&self) -> [(&'static str, u64); 15] {
        [
            ("camera_rays", self.camera_rays),
            ("shadow_rays", self.shadow_rays),
            ("reflection_rays", self.reflection_rays),
            ("refraction_rays", self.refraction_rays),
            ("path_rays", self.path_rays),
            ("random_rays", self.random_rays),
            ("nodes_visited", self.nodes_visited),
            ("box_tests", self.box_tests),
            ("bounding_sphere_tests", self.bounding_sphere_tests),
            ("bounding_ellipsoid_tests", self.bounding_ellipsoid_tests),
            ("triangle_tests", self.triangle_tests),
            ("sphere_tests", self.sphere_tests),
            ("ellipsoid_tests", self.ellipsoid_tests),
            ("plane_tests", self.plane_tests),
            ("primitive_hits", self.primitive_hits),
        ]
    }
}

impl AddAssign for Counters {
    fn add_assign(&mut self, o: Self) {
        self.camera_rays += o.camera_rays;
        self.shadow_rays += o.shadow_rays;
        self.reflection_rays += o.reflection_rays;
        self.refraction_rays += o.refraction_rays;
        self.path_rays += o.path_rays;
        self.random_rays += o.random_rays;
        self.nodes_visited += o.nodes_visited;
        self.box_tests += o.box_tests;
        self.bounding_sphere_tests += o.bounding_sphere_tests;
        self.bounding_ellipsoid_tests += o.bounding_ellipsoid_tests;
        self.triangle_tests += o.triangle_tests;
        self.sphere_tests += o.sphere_tests;
        self.ellipsoid_tests += o.ellipsoid_tests;
        self.plane_tests += o.plane_tests;
        self.primitive_hits += o.primitive_hits;
    }
}

impl Stats for Counters {
    const ENABLED: bool = true;
    #[inline(always)]
    fn ray(&mut self, kind: RayKind) {
        match kind {
            RayKind::Camera => self.camera_rays += 1,
            RayKind::Shadow => self.shadow_rays += 1,
            RayKind::Reflection => self.reflection_rays += 1,
            RayKind::Refraction => self.refraction_rays += 1,
            RayKind::Path => self.path_rays += 1,
            RayKind::Random => self.random_rays += 1,
        }
    }
    #[inline(always)]
    fn node_visit(&mut self) {
        self.nodes_visited += 1;
    }
    #[inline(always)]
    fn box_test(&mut self) {
        self.box_tests += 1;
    }
    #[inline(always)]
    fn boxes_tested(&mut self, n: u32) {
        self.box_tests += u64::from(n);
    }
    #[inline(always)]
    fn bounding_sphere_test(&mut self) {
        self.bounding_sphere_tests += 1;
    }
    #[inline(always)]
    fn bounding_ellipsoid_test(&mut self) {
        self.bounding_ellipsoid_tests += 1;
    }
    #[inline(always)]
    fn triangle_test(&mut self) {
        self.triangle_tests += 1;
    }
    #[inline(always)]
    fn triangles_tested(&mut self, n: u32) {
        self.triangle_tests += u64::from(n);
    }
    #[inline(always)]
    fn sphere_test(&mut self) {
        self.sphere_tests += 1;
    }
    #[inline(always)]
    fn ellipsoid_test(&mut self) {
        self.ellipsoid_tests += 1;
    }
    #[inline(always)]
    fn plane_test(&mut self) {
        self.plane_tests += 1;
    }
    #[inline(always)]
    fn primitive_hit(&mut self) {
        self.primitive_hits += 1;
    }
}

impl AddAssign for NoStats {
    #[inline(always)]
    fn add_assign(&mut self, _: Self) {}
}

/// Counts rays by kind and nothing else: cheap enough to leave on when a
/// command only reports rays per second.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounts(pub Counters);

impl Stats for RayCounts {
    const ENABLED: bool = true;
    #[inline(always)]
    fn ray(&mut self, kind: RayKind) {
        self.0.ray(kind);
    }
}

impl AddAssign for RayCounts {
    fn add_assign(&mut self, o: Self) {
        self.0 += o.0;
    }
}
