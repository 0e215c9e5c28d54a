//! Errors of reading and writing results and the files beside them (claims files): one line
//! each, naming the file, key or line, and the problem. The harness's own error
//! (`tb_harness::HarnessError`) takes each of them as it reads.

use std::path::PathBuf;

/// An error of reading or writing results or a file beside them; its Display is one line.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A problem of a file's content, found before any work starts.
    #[error("{file}:{line}: {key}: {message}")]
    Config {
        /// The file the problem is in.
        file: PathBuf,
        /// 1-based line of the problem in the file.
        line: usize,
        /// The key or column the problem is about.
        key: String,
        /// What is wrong there.
        message: String,
    },
    /// A TOML syntax or type error (toml's message already names the line).
    #[error("{file}: {message}")]
    ConfigSyntax {
        /// The file that does not parse.
        file: PathBuf,
        /// toml's message.
        message: String,
    },
    /// An I/O or CSV error on a file or folder.
    #[error("{path}: {message}")]
    Io {
        /// The file or folder being read or written.
        path: PathBuf,
        /// The underlying error's message.
        message: String,
    },
    /// Any other problem, already worded as one line.
    #[error("{0}")]
    Other(String),
}

impl Error {
    /// An [`Error::Io`] on `path` with `e`'s message.
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
