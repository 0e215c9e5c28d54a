//! A scene from its source string: `builtin:…` or a file path under the scenes root.

use crate::error::SceneError;
use crate::scene::Scene;
use crate::{builtin, loader};
use std::path::{Component, Path, PathBuf};

/// Load a scene: `builtin:NAME?k=v&…` or a file path, resolved against `scenes_root` when
/// relative. Errors name the file (and line, for OBJ) and the problem.
pub fn load(source: &str, scenes_root: &Path) -> Result<Scene, SceneError> {
    if let Some(spec) = source.strip_prefix("builtin:") {
        builtin::load(spec)
    } else {
        let path = resolve(source, scenes_root);
        let mut scene = loader::load_file(&path)?;
        scene.source = source.to_string();
        Ok(scene)
    }
}

/// Where a file scene's source is: an absolute path, or one beginning with `./` or `../`
/// (relative to the current directory), as given; any other path under `scenes_root`.
pub fn resolve(source: &str, scenes_root: &Path) -> PathBuf {
    let p = Path::new(source);
    match p.components().next() {
        Some(
            Component::RootDir | Component::Prefix(_) | Component::CurDir | Component::ParentDir,
        ) => p.to_path_buf(),
        _ => scenes_root.join(p),
    }
}
