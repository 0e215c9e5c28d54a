//! The scene: triangles with what the loader knows about them, and a built-in scene's view.

use crate::camera::Camera;
use tb_core::{Aabb, Ray, Triangle, Vec3};

/// A default view for a scene: camera, optional point light, AO distance.
#[derive(Clone, Debug, PartialEq)]
pub struct View {
    pub camera: Camera,
    /// Point light for shadow rays; `None` means the scene has no light (shadow rays skipped).
    pub light: Option<Vec3>,
    /// Maximum AO ray length.
    pub ao_distance: f32,
}

/// Triangles to trace, with what the loader knows about them.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The source string it was loaded from (`builtin:…` or the path as given).
    pub source: String,
    /// All triangles (polygons triangulated, all groups, objects and glTF nodes merged, node
    /// transforms applied). Degenerate triangles are kept.
    pub triangles: Vec<Triangle>,
    /// Bounds of all vertices.
    pub bounds: Aabb,
    /// A default view, for built-in scenes (files have none; configs give one).
    pub view: Option<View>,
    /// Stress scenes come with their own rays, built to hit the case they test (closest-hit
    /// queries, traced as ray kind `stress`).
    pub own_rays: Vec<Ray>,
}

impl Scene {
    /// A scene from triangles, computing bounds.
    pub fn from_triangles(source: impl Into<String>, triangles: Vec<Triangle>) -> Self {
        let bounds = triangles
            .iter()
            .fold(Aabb::EMPTY, |b, t| b.union(&t.bounds()));
        Scene {
            source: source.into(),
            triangles,
            bounds,
            view: None,
            own_rays: Vec::new(),
        }
    }

    /// Number of triangles with zero area.
    pub fn degenerate_count(&self) -> usize {
        self.triangles.iter().filter(|t| t.is_degenerate()).count()
    }

    /// Bytes of the triangle array.
    pub fn memory_bytes(&self) -> usize {
        std::mem::size_of_val(self.triangles.as_slice())
    }
}
