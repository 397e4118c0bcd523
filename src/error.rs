//! The library's one error type: every message names the file, node, accessor or key at fault.

use std::path::{Path, PathBuf};

/// Everything that can go wrong in the library. Each variant renders as one line that names
/// what is at fault, so the CLI and the Blender add-on can show it to a user as it is.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The scene file cannot be read or is not valid glTF 2.0.
    #[error("{path}: {message}")]
    Scene { path: PathBuf, message: String },

    /// Valid glTF that asks for something we do not render (Draco, a required extension...).
    #[error("{path}: unsupported: {message}")]
    Unsupported { path: PathBuf, message: String },

    /// The scene holds no triangle to render.
    #[error("{0}: the scene has no triangles to render")]
    EmptyScene(PathBuf),

    /// A setting (flag or JSON key) has an impossible value.
    #[error("invalid setting `{key}`: {message}")]
    Setting { key: &'static str, message: String },

    /// The JSON settings file is unreadable, not JSON, or has unknown keys.
    #[error("settings {path}: {message}")]
    Config { path: PathBuf, message: String },

    /// An image we were asked to read (facet map, palette painting, layout) is unusable.
    #[error("{path}: {message}")]
    Input { path: PathBuf, message: String },

    /// Writing an output file failed.
    #[error("cannot write {path}: {message}")]
    Output { path: PathBuf, message: String },

    /// A failure of the renderer, not of the user's input: buffers whose sizes disagree, a
    /// solver that did not converge. Exits with 1, like any runtime failure, never with the
    /// usage code.
    #[error("internal error: {0}")]
    Internal(String),

    /// The render was cancelled from outside (the add-on's cancel button).
    #[error("cancelled")]
    Cancelled,
}

/// Joins a message's lines: messages from other crates (the image decoders) may span several,
/// and ours are one line (found by fuzzing a JPEG texture).
fn one_line(message: String) -> String {
    if !message.contains(['\n', '\r']) {
        return message;
    }
    message.lines().map(str::trim).filter(|l| !l.is_empty()).collect::<Vec<_>>().join(" ")
}

impl Error {
    pub fn scene(path: &Path, message: impl Into<String>) -> Self {
        Error::Scene { path: path.to_path_buf(), message: one_line(message.into()) }
    }

    pub fn setting(key: &'static str, message: impl Into<String>) -> Self {
        Error::Setting { key, message: message.into() }
    }

    pub fn input(path: &Path, message: impl Into<String>) -> Self {
        Error::Input { path: path.to_path_buf(), message: one_line(message.into()) }
    }

    pub fn output(path: &Path, message: impl std::fmt::Display) -> Self {
        Error::Output { path: path.to_path_buf(), message: message.to_string() }
    }

    /// Usage errors (a bad flag or settings value) exit with 2, everything else with 1.
    pub fn is_usage(&self) -> bool {
        matches!(self, Error::Setting { .. } | Error::Config { .. })
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
