//! How a command that renders reports: its progress, its files, its warnings and timings.

use std::io::IsTerminal;
use std::path::Path;
use std::time::Duration;

use crate::cli::ProgressMode;
use crate::error::Result;
use crate::output::{Gray16, Outputs, Pass, pass_path};
use crate::pipeline::Stage;
use crate::progress::Progress;

/// Writes a line to stderr. Never `eprintln!`: it panics (exit 101) when stderr is closed or
/// its reader went away; a message that cannot be written is dropped and the exit code says it.
pub fn say(line: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr(), "{line}");
}

/// The progress a command shows for `--progress`: a bar (on a terminal, for `auto`), the
/// add-on's `PROGRESS <fraction> <stage>` lines, or nothing.
pub(super) fn progress_for(mode: ProgressMode) -> Progress {
    let mode = match mode {
        ProgressMode::Auto if std::io::stderr().is_terminal() => ProgressMode::Bar,
        ProgressMode::Auto => ProgressMode::None,
        m => m,
    };
    match mode {
        ProgressMode::Bar => {
            let bar = indicatif::ProgressBar::new(1000);
            bar.set_style(
                indicatif::ProgressStyle::with_template("{msg:>12} [{bar:40}] {percent:>3}%")
                    .expect("static template")
                    .progress_chars("=> "),
            );
            Progress::new(Box::new(move |stage, f| {
                bar.set_message(stage.to_string());
                bar.set_position((f * 1000.0) as u64);
                if f >= 1.0 && stage == Stage::Done.name() {
                    bar.finish_and_clear();
                }
            }))
        }
        ProgressMode::Lines => Progress::new(Box::new(|stage, f| say(&format!("PROGRESS {f:.4} {stage}")))),
        _ => Progress::silent(),
    }
}

/// Adds a command's files to the set written all or nothing.
pub(super) type AddFiles<'o> = Box<dyn FnOnce(&mut Outputs<'o>) -> Result<()> + 'o>;

/// A command's files, for `write_and_report`.
pub(super) enum Files<'o> {
    /// Added by the closure and written all or nothing, under the `writing` stage.
    Staged(AddFiles<'o>),
    /// Added by the closure and written all or nothing, with no stage of their own.
    Quiet(AddFiles<'o>),
    /// Nothing left to write: written as each was done (the frames of a sequence).
    Written,
}

/// The end every command that renders shares: writes its files (none if one cannot be), ends
/// `progress` when given (its `done` stage), prints each warning, then with `verbose` the
/// lines `details` makes (the scene, the camera, each step's time).
pub(super) fn write_and_report(
    files: Files<'_>,
    progress: Option<&Progress>,
    warnings: &[String],
    verbose: bool,
    details: impl FnOnce() -> Vec<String>,
) -> Result<()> {
    let (staged, fill) = match files {
        Files::Staged(fill) => (true, Some(fill)),
        Files::Quiet(fill) => (false, Some(fill)),
        Files::Written => (false, None),
    };
    if staged && let Some(progress) = progress {
        progress.begin(Stage::Writing.name(), 1);
    }
    if let Some(fill) = fill {
        let mut outputs = Outputs::new();
        fill(&mut outputs)?;
        outputs.commit()?;
    }
    if let Some(progress) = progress {
        progress.begin(Stage::Done.name(), 1);
        progress.finish();
    }
    for w in warnings {
        say(&format!("warning: {w}"));
    }
    if verbose {
        for line in details() {
            say(&line);
        }
    }
    Ok(())
}

/// Adds a render's picture at `path` and each pass beside it (`pass_path`), for one
/// all-or-nothing commit.
pub(super) fn add_picture<'a>(
    outputs: &mut Outputs<'a>,
    path: &Path,
    image: &'a image::RgbaImage,
    passes: &'a [(Pass, image::RgbaImage)],
    passes16: &'a [(Pass, Gray16)],
) -> Result<()> {
    outputs.png(path, image)?;
    for (pass, img) in passes {
        outputs.png(&pass_path(path, pass.as_str()), img)?;
    }
    for (pass, img) in passes16 {
        outputs.png16(&pass_path(path, pass.as_str()), img)?;
    }
    Ok(())
}

/// A duration as the timings print it: milliseconds.
pub(super) fn ms(t: Duration) -> f64 {
    t.as_secs_f64() * 1e3
}
