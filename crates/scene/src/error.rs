//! Errors of scene loading.

use std::path::PathBuf;

/// Why a scene could not be loaded. Display is one line naming the file or source.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// An unreadable or malformed scene file.
    #[error("{path}: {message}")]
    File {
        /// The scene file.
        path: PathBuf,
        /// What is wrong with it (one line).
        message: String,
    },
    /// A scene file that does not exist.
    #[error("{path}: file not found")]
    NotFound {
        /// The path looked up.
        path: PathBuf,
    },
    /// A `builtin:` source with an unknown name or a bad parameter.
    #[error("builtin:{spec}: {message}")]
    Builtin {
        /// The source after `builtin:` (name and parameters).
        spec: String,
        /// What is wrong with it (one line).
        message: String,
    },
}
