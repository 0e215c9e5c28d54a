//! Harness errors: one line each, naming the file, key or line, and the problem.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum HarnessError {
    /// A config problem found before any work starts.
    #[error("{file}:{line}: {key}: {message}")]
    Config {
        file: PathBuf,
        line: usize,
        key: String,
        message: String,
    },
    /// A TOML syntax or type error (toml's message already names the line).
    #[error("{file}: {message}")]
    ConfigSyntax { file: PathBuf, message: String },
    #[error("{0}")]
    Scene(#[from] tb_scene::SceneError),
    #[error("{path}: {message}")]
    Io { path: PathBuf, message: String },
    #[error("{0}")]
    Other(String),
}

impl HarnessError {
    pub fn io(path: impl Into<PathBuf>, e: impl std::fmt::Display) -> Self {
        HarnessError::Io {
            path: path.into(),
            message: e.to_string(),
        }
    }
}
