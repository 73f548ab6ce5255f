//! The library's error type. Every error names the file it concerns and, for
//! parse errors, where in it (element, row, byte offset or line).

use std::fmt::Display;

/// An error from reading, writing or validating data.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The operating system refused an operation on `path`.
    #[error("{path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    /// `path` is not a valid file of the expected format; `msg` says where and why.
    #[error("{path}: {msg}")]
    Format { path: String, msg: String },
    /// The inputs are well-formed but cannot be used as asked (wrong kind of
    /// data, inconsistent sizes, an option that does not apply).
    #[error("{0}")]
    Invalid(String),
    /// A usage error found while running (an output path that is an
    /// input, a flag whose value cannot work with the data): the command
    /// exits with 2, as for the usage errors the argument parser finds.
    #[error("{0}")]
    Usage(String),
}

/// Result alias used across the library.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// An I/O error on `path`.
    pub fn io(path: impl Display, source: std::io::Error) -> Self {
        Error::Io {
            path: path.to_string(),
            source,
        }
    }

    /// A format error in `path`.
    pub fn format(path: impl Display, msg: impl Into<String>) -> Self {
        Error::Format {
            path: path.to_string(),
            msg: msg.into(),
        }
    }

    /// A usage error (exit code 2).
    pub fn usage(msg: impl Into<String>) -> Self {
        Error::Usage(msg.into())
    }

    /// Invalid input or options.
    pub fn invalid(msg: impl Into<String>) -> Self {
        Error::Invalid(msg.into())
    }

    /// A validation error found in the contents of `path`: an
    /// [`Error::Invalid`] becomes an [`Error::Format`] naming the file;
    /// other errors (which name their file already) are kept.
    pub fn in_file(self, path: impl Display) -> Self {
        match self {
            Error::Invalid(msg) => Error::format(path, msg),
            e => e,
        }
    }

    /// The same error with the role of its file in front of the path
    /// ("prediction mesh.ply: ..."), for commands that read several files
    /// of one kind; an [`Error::Invalid`] gets "role: " in front.
    pub fn in_role(self, role: &str) -> Self {
        match self {
            Error::Io { path, source } => Error::Io {
                path: format!("{role} {path}"),
                source,
            },
            Error::Format { path, msg } => Error::Format {
                path: format!("{role} {path}"),
                msg,
            },
            Error::Invalid(msg) => Error::Invalid(format!("{role}: {msg}")),
            Error::Usage(msg) => Error::Usage(format!("{role}: {msg}")),
        }
    }
}
