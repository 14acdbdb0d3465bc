//! Errors the renderer reports to its user. Bad input is always `PrismError::Input` with a
//! one-line message naming the file and what is wrong; the CLI maps it to exit code 2.

use std::fmt;

#[derive(Debug)]
pub enum PrismError {
    /// The user's input (scene, materials JSON, flags) is wrong. Exit code 2.
    Input(String),
    /// Something failed that is not the user's fault (I/O on output, internal invariant). Exit code 1.
    Internal(String),
}

impl PrismError {
    pub fn input(msg: impl Into<String>) -> Self {
        PrismError::Input(msg.into())
    }
    pub fn internal(msg: impl Into<String>) -> Self {
        PrismError::Internal(msg.into())
    }
    pub fn exit_code(&self) -> i32 {
        match self {
            PrismError::Input(_) => 2,
            PrismError::Internal(_) => 1,
        }
    }
}

impl fmt::Display for PrismError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PrismError::Input(m) | PrismError::Internal(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for PrismError {}

pub type Result<T> = std::result::Result<T, PrismError>;
