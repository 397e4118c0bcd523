//! Each subcommand's body, called by the binary once its flags are parsed: one file a command.
//!
//! A command resolves its settings, loads the scene, runs the pipeline and reports through
//! `report` (files written all or nothing, warnings, `--verbose` timings), so every command
//! that renders ends the same way.

mod faces;
mod facets;
mod frames;
mod look;
mod render;
mod report;
mod saliency;
mod serve;
mod settings;

pub use faces::faces;
pub use facets::facets;
pub use look::look;
pub use render::render;
pub use report::say;
pub use saliency::saliency;
pub use serve::serve;
pub use settings::settings;

use crate::error::{Error, Result};

/// Prints `text` and a newline on stdout. A reader that went away (`cubist settings | head`)
/// ends the output quietly instead of panicking like `println!`.
fn emit(text: &str) -> Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match writeln!(out, "{text}").and_then(|()| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(system(&e)),
        _ => Ok(()),
    }
}

/// A failure of the system around the renderer (stdout, a folder, a file the library does not
/// write itself) as one message: the error, then each cause after a colon.
fn system(e: &dyn std::error::Error) -> Error {
    let mut message = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        message += &format!(": {c}");
        cause = c.source();
    }
    Error::System(message)
}

/// JSON text of a value the commands print: serializing their own maps and settings cannot
/// fail, so a failure is the renderer's.
fn json(value: &impl serde::Serialize, pretty: bool) -> Result<String> {
    let text = if pretty { serde_json::to_string_pretty(value) } else { serde_json::to_string(value) };
    text.map_err(|e| Error::Internal(format!("JSON output: {e}")))
}
