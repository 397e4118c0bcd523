//! The library's one error type: every message names the file, node, accessor or key at fault.

use std::path::{Path, PathBuf};

/// Everything that can go wrong in the library. Each variant renders as one line that names
/// what is at fault, so the CLI and the Blender add-on can show it to a user as it is.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The scene file cannot be read or is not valid glTF 2.0.
    #[error("{}: {message}", short_path(path))]
    Scene { path: PathBuf, message: String },

    /// Valid glTF that asks for something we do not render (Draco, a required extension...).
    #[error("{}: unsupported: {message}", short_path(path))]
    Unsupported { path: PathBuf, message: String },

    /// The scene holds no triangle to render.
    #[error("{}: the scene has no triangles to render", short_path(.0))]
    EmptyScene(PathBuf),

    /// A setting (flag or JSON key) has an impossible value.
    #[error("invalid setting `{key}`: {message}")]
    Setting { key: &'static str, message: String },

    /// The JSON settings file is unreadable, not JSON, or has unknown keys.
    #[error("settings {}: {message}", short_path(path))]
    Config { path: PathBuf, message: String },

    /// An image we were asked to read (facet map, palette painting, layout) is unusable.
    #[error("{}: {message}", short_path(path))]
    Input { path: PathBuf, message: String },

    /// Writing an output file failed.
    #[error("cannot write {}: {message}", short_path(path))]
    Output { path: PathBuf, message: String },

    /// A failure of the renderer, not of the user's input: buffers whose sizes disagree, a
    /// solver that did not converge. Exits with 1, like any runtime failure, never with the
    /// usage code.
    #[error("internal error: {0}")]
    Internal(String),

    /// The render was cancelled from outside (the add-on's cancel button).
    #[error("cancelled")]
    Cancelled,

    /// The system refused something around the renderer (writing stdout, making the frames'
    /// folder, writing a JPEG contact sheet): what was being done and the system's message.
    #[error("{0}")]
    System(String),

    /// A value inside a command's own argument that does not parse (`faces --view planar:abc`,
    /// whose number clap leaves to the command). Exits with 1: it is found after parsing.
    #[error("{0}")]
    Argument(String),
}

/// Longest echo of a user-given string (a path, a number, a name) in a message, characters.
pub const MAX_ECHO: usize = 120;

/// Shortens a user-given string for a one-line message: at most `MAX_ECHO` characters, the
/// middle replaced by an ellipsis (a 50 MB path or a 300-digit number is not echoed whole).
pub fn shorten(s: &str) -> String {
    let n = s.chars().count();
    if n <= MAX_ECHO {
        return s.to_string();
    }
    let head: String = s.chars().take(MAX_ECHO / 2).collect();
    let tail: String = s.chars().skip(n - (MAX_ECHO / 2 - 1)).collect();
    format!("{head}…{tail}")
}

/// A path as a message shows it: shortened.
pub fn short_path(p: &Path) -> String {
    shorten(&p.display().to_string())
}

/// A number as a message shows it: as written (`150`) when short, else in exponent form
/// (`1e308`, where `{}` prints 309 digits).
pub fn short_num(v: f64) -> String {
    let plain = format!("{v}");
    if plain.len() <= 12 { plain } else { shorten(&format!("{v:e}")) }
}

/// Longest message, characters: a message is one line; longer ones (a decoder's error that
/// echoes its input, a mesh named with a megabyte) are cut in the middle.
pub const MAX_MESSAGE: usize = 600;

/// Cuts a whole message to `MAX_MESSAGE` characters, keeping its start and end.
pub fn cap_message(s: &str) -> String {
    let n = s.chars().count();
    if n <= MAX_MESSAGE {
        return s.to_string();
    }
    let head: String = s.chars().take(MAX_MESSAGE / 2).collect();
    let tail: String = s.chars().skip(n - (MAX_MESSAGE / 2 - 1)).collect();
    format!("{head}…{tail}")
}

/// Joins a message's lines: messages from other crates (the image decoders) may span several,
/// and ours are one line (found by fuzzing a JPEG texture).
fn one_line(message: String) -> String {
    if !message.contains(['\n', '\r']) {
        return cap_message(&message);
    }
    cap_message(&message.lines().map(str::trim).filter(|l| !l.is_empty()).collect::<Vec<_>>().join(" "))
}

impl Error {
    pub fn scene(path: &Path, message: impl Into<String>) -> Self {
        Error::Scene { path: path.to_path_buf(), message: one_line(message.into()) }
    }

    pub fn setting(key: &'static str, message: impl Into<String>) -> Self {
        Error::Setting { key, message: one_line(message.into()) }
    }

    pub fn config(path: &Path, message: impl Into<String>) -> Self {
        Error::Config { path: path.to_path_buf(), message: one_line(message.into()) }
    }

    pub fn input(path: &Path, message: impl Into<String>) -> Self {
        Error::Input { path: path.to_path_buf(), message: one_line(message.into()) }
    }

    pub fn output(path: &Path, message: impl std::fmt::Display) -> Self {
        Error::Output { path: path.to_path_buf(), message: one_line(message.to_string()) }
    }

    /// Usage errors (a bad flag or settings value) exit with 2, everything else with 1.
    pub fn is_usage(&self) -> bool {
        matches!(self, Error::Setting { .. } | Error::Config { .. })
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_paths_numbers_and_messages_are_shortened() {
        assert_eq!(shorten("abc"), "abc");
        let long = "x".repeat(10_000) + "END";
        let s = shorten(&long);
        assert!(s.chars().count() <= MAX_ECHO && s.contains('…') && s.ends_with("END"), "{s}");
        // Multi-byte characters are never split.
        assert!(shorten(&"é".repeat(1000)).chars().count() <= MAX_ECHO);
        assert_eq!(short_num(1e308), "1e308");
        let e = Error::input(Path::new(&"d/".repeat(100_000)), "m".repeat(100_000)).to_string();
        assert!(e.chars().count() <= MAX_ECHO + MAX_MESSAGE + 2, "{} chars", e.len());
    }
}
