//! trace-bench scenes and rays.
//!
//! - [`load`]: a scene from a source string: `builtin:NAME?param=value&…` (see [`builtin`] and
//!   [`stress`]) or a file path (`.obj`, `.obj.gz`, `.gltf`, `.glb`) relative to the scenes root;
//! - [`camera`]: the pinhole camera of the configs, row or Morton pixel order;
//! - [`rays`]: the ray batches every structure traces (primary, shadow, ao, path bounces,
//!   random), generated once per scene and kind with fixed seeds;
//! - [`conformance`]: the shared oracle suite every structure x traversal must pass.

pub mod builtin;
pub mod camera;
pub mod conformance;
pub mod error;
pub mod loader;
pub mod procedural;
pub mod rays;
pub mod stress;

pub use camera::{Camera, PixelOrder};
pub use error::SceneError;

use std::path::Path;
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

/// Load a scene: `builtin:NAME?k=v&…` or a file path, resolved against `scenes_root` when
/// relative. Errors name the file (and line, for OBJ) and the problem.
pub fn load(source: &str, scenes_root: &Path) -> Result<Scene, SceneError> {
    if let Some(spec) = source.strip_prefix("builtin:") {
        builtin::load(spec)
    } else {
        let p = Path::new(source);
        let path = if p.is_absolute() {
            p.to_path_buf()
        } else {
            scenes_root.join(p)
        };
        let mut scene = loader::load_file(&path)?;
        scene.source = source.to_string();
        Ok(scene)
    }
}
