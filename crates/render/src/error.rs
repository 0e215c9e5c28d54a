//! Rendering errors: one line each, naming the file and the problem.

use std::path::PathBuf;

/// An error reading or writing an image, or a mismatch between two images.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// An I/O, PNG or EXR error on a file.
    #[error("{path}: {message}")]
    File {
        /// The image file read or written.
        path: PathBuf,
        /// What went wrong with it.
        message: String,
    },
    /// Two images (or an image and what was asked of it) do not fit together.
    #[error("{0}")]
    Mismatch(String),
}

impl RenderError {
    /// An error on `path`.
    pub fn file(path: impl Into<PathBuf>, e: impl std::fmt::Display) -> Self {
        RenderError::File {
            path: path.into(),
            message: e.to_string(),
        }
    }
}
