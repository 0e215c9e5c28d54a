//! Errors of scene loading.

use std::path::PathBuf;

/// Why a scene could not be loaded. Display is one line naming the file or source.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("{path}: {message}")]
    File { path: PathBuf, message: String },
    #[error("{path}: file not found")]
    NotFound { path: PathBuf },
    #[error("builtin:{spec}: {message}")]
    Builtin { spec: String, message: String },
}
