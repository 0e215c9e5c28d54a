//! File loaders. TODO(helper A).

use crate::{Scene, SceneError};
use std::path::Path;

/// Load `.obj`, `.obj.gz`, `.gltf` or `.glb`.
pub fn load_file(path: &Path) -> Result<Scene, SceneError> {
    Err(SceneError::NotFound {
        path: path.to_path_buf(),
    })
}
