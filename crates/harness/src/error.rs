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

/// An error of reading or writing results (tb-results) or a claims file, the same line.
impl From<tb_results::Error> for HarnessError {
    fn from(e: tb_results::Error) -> Self {
        match e {
            tb_results::Error::Config {
                file,
                line,
                key,
                message,
            } => HarnessError::Config {
                file,
                line,
                key,
                message,
            },
            tb_results::Error::ConfigSyntax { file, message } => {
                HarnessError::ConfigSyntax { file, message }
            }
            tb_results::Error::Io { path, message } => HarnessError::Io { path, message },
            tb_results::Error::Other(m) => HarnessError::Other(m),
        }
    }
}
