//! Errors of reading and writing results and the files beside them (claims files): one line
//! each, naming the file, key or line, and the problem. The harness's own error
//! (`tb_harness::HarnessError`) takes each of them as it reads.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A problem of a file's content, found before any work starts.
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
    #[error("{path}: {message}")]
    Io { path: PathBuf, message: String },
    #[error("{0}")]
    Other(String),
}

impl Error {
    pub fn io(path: impl Into<PathBuf>, e: impl std::fmt::Display) -> Self {
        Error::Io {
            path: path.into(),
            message: e.to_string(),
        }
    }
}

/// 1-based line of byte offset `pos` in `text`.
pub fn line_of(text: &str, pos: usize) -> usize {
    text[..pos.min(text.len())]
        .bytes()
        .filter(|&b| b == b'\n')
        .count()
        + 1
}
