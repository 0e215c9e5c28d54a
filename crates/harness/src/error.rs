//! Harness errors: one line each, naming the file, key or line, and the problem. A problem of
//! a file (a config, a results or claims file) is tb-results' error, shared with the claims;
//! the harness adds the scenes' own.

use std::path::PathBuf;

/// An error of the harness, one line naming the file, key or line and the problem.
#[derive(Debug, thiserror::Error)]
pub enum HarnessError {
    /// A config problem found before any work starts, a file that cannot be read or
    /// written, or another problem in one line (tb-results' error).
    #[error(transparent)]
    File(#[from] tb_results::Error),
    /// A scene that could not be loaded.
    #[error("{0}")]
    Scene(#[from] tb_scene::SceneError),
}

impl HarnessError {
    /// `path` could not be read or written: `e` says why.
    pub fn io(path: impl Into<PathBuf>, e: impl std::fmt::Display) -> Self {
        HarnessError::File(tb_results::Error::io(path, e))
    }

    /// A problem in one line.
    pub fn other(message: impl Into<String>) -> Self {
        HarnessError::File(tb_results::Error::Other(message.into()))
    }
}
