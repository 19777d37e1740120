//! Errors of the library, one enum for the whole crate; every variant says what went wrong and
//! where (file, field, line), because the CLI prints them as they are.

use std::path::PathBuf;

/// Anything that can go wrong between a scene file and an image.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Bad input: a scene file, a mesh file, an image file, or a setting. Exit code 2.
    #[error("{}", describe_input(.file, .field, .line, .message))]
    Input {
        /// The file at fault (`<command line>` for a command-line argument).
        file: String,
        /// The field, as a JSON path (`lights[0].intensity`) or a setting name; may be empty.
        field: String,
        /// Line and column in the file, where known.
        line: Option<(usize, usize)>,
        /// What is wrong.
        message: String,
    },
    /// No GPU adapter could be found or opened.
    #[error("no GPU adapter: {0}")]
    NoAdapter(String),
    /// The GPU failed (device lost, out of memory, validation error).
    #[error("GPU error: {0}")]
    Device(String),
    /// A shader failed to compile (a bug: shaders are validated in the tests).
    #[error("shader {name}: {message}")]
    Shader {
        /// The stage, as [`crate::gpu::STAGES`] names it.
        name: String,
        /// naga's diagnostic, or the missing entry point or binding.
        message: String,
    },
    /// The caller cancelled the work (the CPU reference's `Progress` was cancelled); nothing
    /// was produced.
    #[error("cancelled")]
    Cancelled,
    /// Writing an output file failed.
    #[error("cannot write {}: {message}", .path.display())]
    Output {
        /// The file or folder that could not be written.
        path: PathBuf,
        /// Why.
        message: String,
    },
}

fn describe_input(file: &str, field: &str, line: &Option<(usize, usize)>, message: &str) -> String {
    let mut s = format!("{file}: ");
    if let Some((l, c)) = line {
        s += &format!("line {l}, column {c}: ");
    }
    if !field.is_empty() {
        s += &format!("field `{field}`: ");
    }
    s + message
}

impl Error {
    /// An input error naming the file and field.
    pub fn input(file: impl Into<String>, field: impl Into<String>, message: impl Into<String>) -> Self {
        let field = field.into();
        Error::Input { file: file.into(), field, line: None, message: message.into() }
    }

    /// Whether this error is the user's input (exit code 2) rather than the machine's.
    pub fn is_input(&self) -> bool {
        matches!(self, Error::Input { .. } | Error::Output { .. })
    }
}

/// The crate's result: [`Error`] unless another error type is given.
pub type Result<T, E = Error> = std::result::Result<T, E>;
