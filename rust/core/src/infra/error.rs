//! Typed errors of the core. The binding crate maps each variant to a Python exception
//! (`splitlf.errors`): the two bad-input variants to `InvalidParameter` (a `ValueError`),
//! the size variants to `TooLargeError` (a `MemoryError`).

use std::fmt;

/// Everything the core can refuse. No function of the core panics on user input:
/// it returns one of these, before any work starts where the check can be made up front.
#[derive(Debug, Clone, PartialEq)]
pub enum Error {
    /// A camera or call parameter outside its allowed range.
    InvalidParameter {
        name: &'static str,
        value: String,
        allowed: String,
        /// The channel (numbered from 1) of a design whose field `name` is meant, if any.
        channel: Option<usize>,
    },
    /// One element of a depth array is not a valid depth.
    InvalidDepth {
        index: usize,
        value: f64,
        reason: String,
    },
    /// The outputs and working buffers would not fit in the memory available (checked
    /// before any work), or an allocation failed.
    TooLarge {
        what: String,
        bytes: u128,
        limit: u128,
    },
    /// The work asked for exceeds a stated limit (in `unit`s), refused before it starts.
    TooMuchWork {
        what: String,
        amount: u128,
        limit: u128,
        unit: &'static str,
    },
    /// The caller's interrupt check (see [`crate::infra::parallel::checkpoint`]) asked to stop.
    Interrupted,
}

/// A number as an error message shows it: plain decimal when short, scientific otherwise
/// (Rust's `{}` spells 5e-324 with 324 digits).
pub fn short_number(x: f64) -> String {
    let plain = x.to_string();
    if plain.len() <= 20 {
        plain
    } else {
        format!("{x:e}")
    }
}

/// A value's text for a message: numbers that print long are shortened (see
/// [`short_number`]), anything else is kept, cut at 120 characters.
fn short_value(text: String) -> String {
    if text.len() > 20 {
        if let Ok(x) = text.parse::<f64>() {
            return short_number(x);
        }
    }
    if text.chars().count() > 120 {
        let cut: String = text.chars().take(117).collect();
        return format!("{cut}...");
    }
    text
}

impl Error {
    pub fn param(name: &'static str, value: impl fmt::Display, allowed: impl Into<String>) -> Self {
        Error::InvalidParameter {
            name,
            value: short_value(value.to_string()),
            allowed: allowed.into(),
            channel: None,
        }
    }

    /// The same error, said of channel `number` (from 1) of a design: an invalid parameter
    /// is then named `channels[number].name`.
    pub fn in_channel(self, number: usize) -> Self {
        match self {
            Error::InvalidParameter {
                name,
                value,
                allowed,
                ..
            } => Error::InvalidParameter {
                name,
                value,
                allowed,
                channel: Some(number),
            },
            other => other,
        }
    }

    /// The parameter's full name: `name`, or `channels[i].name` for a design's channel i.
    pub fn parameter_name(&self) -> Option<String> {
        match self {
            Error::InvalidParameter {
                name,
                channel: Some(i),
                ..
            } => Some(format!("channels[{i}].{name}")),
            Error::InvalidParameter { name, .. } => Some(name.to_string()),
            _ => None,
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::InvalidParameter { value, allowed, .. } => {
                let name = self.parameter_name().unwrap_or_default();
                write!(f, "invalid {name} = {value}: allowed {allowed}")
            }
            Error::InvalidDepth {
                index,
                value,
                reason,
            } => write!(
                f,
                "invalid depth z[{index}] = {}: {reason}",
                short_number(*value)
            ),
            Error::TooLarge { what, bytes, limit } => write!(
                f,
                "{what} needs {bytes} bytes ({:.3} GB), more than the {limit} bytes ({:.3} GB) available",
                *bytes as f64 / 1e9,
                *limit as f64 / 1e9
            ),
            Error::TooMuchWork {
                what,
                amount,
                limit,
                unit,
            } => write!(
                f,
                "{what} is {amount} {unit}, more than the limit of {limit} {unit}"
            ),
            Error::Interrupted => write!(f, "interrupted"),
        }
    }
}

impl std::error::Error for Error {}

pub type Result<T> = std::result::Result<T, Error>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_stay_short() {
        let e = Error::InvalidDepth {
            index: 0,
            value: 5e-324,
            reason: "depths must be > F".into(),
        };
        assert!(e.to_string().len() < 60, "{e}");
        let e = Error::param("F", 5e-324, "a finite length > 0 mm");
        assert_eq!(
            e.to_string(),
            "invalid F = 5e-324: allowed a finite length > 0 mm"
        );
        let e = Error::param("F", 1e300, "x");
        assert!(e.to_string().len() < 40, "{e}");
        assert_eq!(
            Error::param("Q", 12, "x").to_string(),
            "invalid Q = 12: allowed x"
        );
    }
}
