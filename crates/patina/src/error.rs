//! The library's one error type.

use std::path::PathBuf;

/// Everything that can go wrong in patina. The CLI maps [`Error::is_usage`]
/// errors (bad input) to exit code 2 and the rest to exit code 1.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be opened or read.
    #[error("cannot read {}: {source}", path.display())]
    Read { path: PathBuf, source: std::io::Error },
    /// A file could not be written.
    #[error("cannot write {}: {source}", path.display())]
    Write { path: PathBuf, source: std::io::Error },
    /// A file was read but is not a valid image of a supported kind.
    #[error("{}: not a readable image ({reason})", path.display())]
    Decode { path: PathBuf, reason: String },
    /// Parameters or inputs that cannot work together (sizes, ranges, shapes).
    #[error("{0}")]
    InvalidInput(String),
    /// A request whose buffers would not fit in memory.
    #[error("{what} needs about {need_mib} MiB of memory but only {available_mib} MiB is available")]
    TooLarge { what: String, need_mib: u64, available_mib: u64 },
    /// A bug or an unexpected failure inside patina.
    #[error("internal error: {0}")]
    Internal(String),
}

impl Error {
    /// True when the user can fix the problem by changing the input, the
    /// flags or the output path: everything but internal failures and
    /// writes that failed for reasons other than the path (a full disk).
    pub fn is_usage(&self) -> bool {
        use std::io::ErrorKind as K;
        match self {
            Error::Internal(_) => false,
            Error::Write { source, .. } => matches!(
                source.kind(),
                K::NotFound
                    | K::PermissionDenied
                    | K::AlreadyExists
                    | K::NotADirectory
                    | K::IsADirectory
                    | K::ReadOnlyFilesystem
                    | K::InvalidInput
            ),
            _ => true,
        }
    }

    /// Shorthand for [`Error::InvalidInput`].
    pub fn invalid(msg: impl Into<String>) -> Self {
        Error::InvalidInput(msg.into())
    }
}

/// Result with patina's [`Error`].
pub type Result<T> = std::result::Result<T, Error>;
