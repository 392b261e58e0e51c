//! The crate's error type: every failure names the file (when there is one)
//! and what is wrong with it.

use std::path::{Path, PathBuf};

/// An rtdiff error.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A problem with a named file (missing, unreadable, malformed).
    #[error("{}: {msg}", path.display())]
    File {
        /// The file in question.
        path: PathBuf,
        /// What is wrong with it.
        msg: String,
    },
    /// A problem at one line of a text file (a mesh, a material library).
    #[error("{}:{line}: {msg}", path.display())]
    Line {
        /// The file in question.
        path: PathBuf,
        /// The line, counted from 1.
        line: usize,
        /// What is wrong there.
        msg: String,
    },
    /// A problem not tied to one file (bad option, invalid parameter).
    #[error("{0}")]
    Invalid(String),
}

impl Error {
    /// An error about `path`.
    pub fn file(path: impl AsRef<Path>, msg: impl Into<String>) -> Self {
        Self::File { path: path.as_ref().to_path_buf(), msg: msg.into() }
    }

    /// An error about line `line` (from 1) of `path`.
    pub fn at(path: impl AsRef<Path>, line: usize, msg: impl Into<String>) -> Self {
        Self::Line { path: path.as_ref().to_path_buf(), line, msg: msg.into() }
    }

    /// An error about a missing or unreadable file, with a hint for the
    /// project's fetched assets.
    pub fn io(path: impl AsRef<Path>, err: &std::io::Error) -> Self {
        let path = path.as_ref();
        let mut msg = match err.kind() {
            std::io::ErrorKind::NotFound => "file not found".to_string(),
            _ => format!("cannot read file: {err}"),
        };
        if err.kind() == std::io::ErrorKind::NotFound && path.components().any(|c| c.as_os_str() == "assets") {
            msg.push_str(" (meshes in assets/ are fetched by scripts/fetch-assets.sh: run it first)");
        }
        Self::file(path, msg)
    }
}

/// Shorthand for results with [`Error`].
pub type Result<T> = std::result::Result<T, Error>;
