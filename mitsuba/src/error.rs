//! The one error type of the scene loader.

use std::fmt;

/// Why a scene could not be loaded.
///
/// Every error names the scene file and, when the problem can be pinned to
/// an element, the 1-based line and column of that element (for a property,
/// the property's own tag), so that `Display` reads like a compiler
/// diagnostic: `scene.xml:12:3: unsupported BSDF plugin 'pplastic'`.
/// Problems inside a referenced mesh or image file are reported at the
/// element that names the file, and the message names the file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LoadError {
    /// The scene file as given by the caller (path or `builtin:<name>`).
    pub file: String,
    /// 1-based line of the offending element, when known.
    pub line: Option<u32>,
    /// 1-based column (in characters) of the offending element, when known.
    pub column: Option<u32>,
    /// What is wrong, in words.
    pub message: String,
}

impl LoadError {
    /// An error at a known position of `file`.
    pub fn at(file: &str, line: u32, column: u32, message: impl Into<String>) -> Self {
        LoadError {
            file: file.to_string(),
            line: Some(line),
            column: Some(column),
            message: message.into(),
        }
    }

    /// An error about `file` as a whole (unreadable file, missing sensor, …).
    pub fn whole_file(file: &str, message: impl Into<String>) -> Self {
        LoadError {
            file: file.to_string(),
            line: None,
            column: None,
            message: message.into(),
        }
    }
}

impl fmt::Display for LoadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (self.line, self.column) {
            (Some(l), Some(c)) => write!(f, "{}:{l}:{c}: {}", self.file, self.message),
            (Some(l), None) => write!(f, "{}:{l}: {}", self.file, self.message),
            _ => write!(f, "{}: {}", self.file, self.message),
        }
    }
}

impl std::error::Error for LoadError {}
