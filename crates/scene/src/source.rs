//! A scene from its source string: `builtin:…` or a file path under the scenes root.

use crate::error::SceneError;
use crate::scene::Scene;
use crate::{builtin, loader};
use std::path::Path;

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
