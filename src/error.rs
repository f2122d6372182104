//! The library's typed error. Every fallible public function returns [`Result`].
//!
//! Messages name the offending joint, link, file, row or parameter so that a user can fix
//! the input without reading the source.

use std::path::PathBuf;

/// Result alias used throughout the library.
pub type Result<T> = std::result::Result<T, Error>;

/// Everything that can go wrong in powertwin.
///
/// What a caller can do about each: [`Error::InvalidInput`], [`Error::Toml`],
/// [`Error::Table`], [`Error::Dataset`] and [`Error::UrdfSyntax`]: fix the input they name;
/// [`Error::Model`]: the robot is not one powertwin supports; [`Error::Numerical`]: the input
/// was accepted but a computation failed on it (report it, or change the data, e.g. a richer
/// excitation); [`Error::Io`]: a file could not be read or written. The CLI exits 1 on any of
/// them.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        source: std::io::Error,
    },
    /// The URDF text is not valid URDF XML.
    #[error("malformed URDF: {0}")]
    UrdfSyntax(String),
    /// The URDF is valid XML but not a robot powertwin can model (names the link or joint).
    #[error("unsupported robot model: {0}")]
    Model(String),
    /// A TOML file (drive, payload, scenario) is malformed or has unknown or missing keys.
    #[error("{file}: {message}")]
    Toml {
        /// The file (or a label for in-memory text).
        file: String,
        /// Parser message, with line and column.
        message: String,
    },
    /// The user's input is wrong: a value is not finite, out of range or of the wrong length,
    /// a name is unknown, options contradict each other. Names the input and what it must be.
    #[error("invalid input: {0}")]
    InvalidInput(String),
    /// A computation failed on input that was valid: a solver did not converge, a matrix that
    /// must be positive definite is not, a result is not finite. Names the computation.
    #[error("numerical failure: {0}")]
    Numerical(String),
    /// A joint position or velocity is outside its limit.
    #[error("joint limit violated: {0}")]
    JointLimit(String),
    /// Inverse kinematics has no solution for the requested pose.
    #[error("unreachable pose: {0}")]
    Unreachable(String),
    /// A regressor does not have full column rank; names the parameters that cannot be identified.
    #[error("rank-deficient regressor (rank {rank} of {cols}): cannot identify {unidentifiable}")]
    RankDeficient {
        /// Numerical rank found.
        rank: usize,
        /// Number of columns.
        cols: usize,
        /// Names of the parameters that are not identifiable from the data.
        unidentifiable: String,
    },
    /// A CSV table is malformed (names the row, 1-based, counting the header as row 1).
    #[error("{file}: row {row}: {message}")]
    Table {
        /// The file.
        file: String,
        /// 1-based row number (header = row 1).
        row: usize,
        /// What is wrong.
        message: String,
    },
    /// A dataset directory is malformed: a file is missing or unreadable, a column is missing,
    /// unexpected or not `f64`, a cell is not finite, or the files disagree (names the file,
    /// and the column and 1-based data row where there is one).
    #[error("{path}: {message}")]
    Dataset {
        /// The file (or the directory when no file is concerned).
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// Rerun logging failed: a viewer could not be spawned or reached, an `.rrd` file could
    /// not be written, or the data could not be encoded.
    #[cfg(feature = "viz")]
    #[error("Rerun: {0}")]
    Viz(String),
}

impl Error {
    /// Wrap an I/O error with the path it concerns.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }

    /// The same error with `context` put in front of its message (kind kept), e.g. which run
    /// of a sweep failed. Errors with structured fields are returned unchanged.
    pub fn context(self, context: &str) -> Self {
        match self {
            Error::InvalidInput(m) => Error::InvalidInput(format!("{context}: {m}")),
            Error::JointLimit(m) => Error::JointLimit(format!("{context}: {m}")),
            Error::Unreachable(m) => Error::Unreachable(format!("{context}: {m}")),
            Error::Model(m) => Error::Model(format!("{context}: {m}")),
            Error::Numerical(m) => Error::Numerical(format!("{context}: {m}")),
            other => other,
        }
    }
}

/// Run `decode`, a dependency's decoder on a user's file, and turn a panic inside it into
/// `Err` with the panic's message. The Parquet decoder (parquet 58.4.1) panics on some
/// corrupt files (found by `tests/fuzz.rs`); a corrupt file must be an error, not a crash.
/// The panic hook still runs (by default it prints the message to stderr).
pub(crate) fn catch_decoder_panic<T>(decode: impl FnOnce() -> T) -> std::result::Result<T, String> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(decode)).map_err(|panic| {
        panic
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| panic.downcast_ref::<&str>().copied())
            .unwrap_or("unknown cause")
            .to_string()
    })
}

/// Check that every value of a slice of the caller's input is finite; `what` names the
/// quantity in the message. Errors: [`Error::InvalidInput`].
pub fn ensure_finite(values: &[f64], what: &str) -> Result<()> {
    match values.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(i) => Err(Error::InvalidInput(format!(
            "{what}[{}] is {} (must be finite)",
            i + 1,
            values[i]
        ))),
    }
}

/// Check that every value of a computed slice (an intermediate or final result, not the
/// caller's input) is finite; `what` names the quantity in the message. Errors:
/// [`Error::Numerical`].
pub fn ensure_finite_result(values: &[f64], what: &str) -> Result<()> {
    ensure_finite(values, what).map_err(|e| match e {
        Error::InvalidInput(m) => Error::Numerical(m),
        other => other,
    })
}
