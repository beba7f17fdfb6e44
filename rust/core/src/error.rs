//! Typed errors of the core. The binding crate maps each variant to a Python exception.

use std::fmt;

/// Everything the core can refuse. No function of the core panics on user input:
/// it returns one of these before any work starts.
#[derive(Debug, Clone, PartialEq)]
pub enum Error {
    /// A camera or call parameter outside its allowed range (Python `ValueError`).
    InvalidParameter {
        name: &'static str,
        value: String,
        allowed: String,
    },
    /// One element of a depth array is not a valid depth (Python `ValueError`).
    InvalidDepth {
        index: usize,
        value: f64,
        reason: String,
    },
    /// The requested output would not fit in memory (Python `ValueError`, raised before any allocation).
    TooLarge {
        what: String,
        bytes: u128,
        limit: u128,
    },
}

impl Error {
    pub fn param(name: &'static str, value: impl fmt::Display, allowed: impl Into<String>) -> Self {
        Error::InvalidParameter {
            name,
            value: value.to_string(),
            allowed: allowed.into(),
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::InvalidParameter {
                name,
                value,
                allowed,
            } => write!(f, "invalid {name} = {value}: allowed {allowed}"),
            Error::InvalidDepth {
                index,
                value,
                reason,
            } => write!(f, "invalid depth z[{index}] = {value}: {reason}"),
            Error::TooLarge { what, bytes, limit } => write!(
                f,
                "{what} needs {bytes} bytes, more than the allowed {limit} bytes"
            ),
        }
    }
}

impl std::error::Error for Error {}

pub type Result<T> = std::result::Result<T, Error>;
