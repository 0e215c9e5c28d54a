//! Where a config came from, for errors naming its file, line and key.

use crate::error::HarnessError;
use std::path::Path;

pub use tb_results::error::line_of;

/// Where a config came from, for errors naming its file and line.
pub(crate) struct Ctx<'a> {
    pub(crate) file: &'a Path,
    pub(crate) text: &'a str,
}

impl Ctx<'_> {
    /// A config error at byte range `span` of the file.
    pub(crate) fn err(
        &self,
        span: std::ops::Range<usize>,
        key: &str,
        message: impl Into<String>,
    ) -> HarnessError {
        HarnessError::File(tb_results::Error::Config {
            file: self.file.to_path_buf(),
            line: line_of(self.text, span.start),
            key: key.to_string(),
            message: message.into(),
        })
    }
}
