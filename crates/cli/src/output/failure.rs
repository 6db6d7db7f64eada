//! The error of an output the command could not complete.

/// A failure that is not the user's fault (exit status 1), for example an output file
/// that cannot be written. Every other error is bad usage or bad input (exit status 2,
/// [`crate::common::report`]).
#[derive(Debug)]
pub struct Failure(pub String);

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Failure {}
