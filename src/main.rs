//! The `cubist` binary: parse flags, call the subcommand's body (`cubist::cli::commands`), map
//! errors to exit codes (1 failure, 2 usage).

use std::process::ExitCode;

use clap::Parser;
use cubist::cli::commands::{self, say};
use cubist::cli::{Cli, Command};

fn main() -> ExitCode {
    handle_signals();
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            if e.use_stderr() {
                say(&usage_error(&e.render().to_string()));
                return ExitCode::from(2);
            }
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
    };
    let result = match cli.command {
        Command::Render(args) => commands::render(args),
        Command::Faces(args) => commands::faces(args),
        Command::Saliency(args) => commands::saliency(args),
        Command::Facets(args) => commands::facets(args),
        Command::Settings(args) => commands::settings(args),
        Command::Look(args) => commands::look(args),
        Command::Serve(args) => commands::serve(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            say(&format!("error: {}", cubist::error::cap_message(&e.to_string())));
            ExitCode::from(if e.is_usage() { 2 } else { 1 })
        }
    }
}

/// clap's usage error as we print it: the first line names the problem (clap ends some first
/// lines with a colon and lists the arguments below), and no line echoes a huge value whole.
fn usage_error(rendered: &str) -> String {
    let lines: Vec<&str> = rendered.trim_end().lines().collect();
    let mut out: Vec<String> = Vec::new();
    let mut i = 0;
    if let Some(first) = lines.first() {
        let mut first = first.trim_end().to_string();
        i = 1;
        if first.ends_with(':') {
            // "the following required arguments were not provided:" + the indented list.
            let mut items = Vec::new();
            while i < lines.len() && lines[i].starts_with(' ') && !lines[i].trim().is_empty() {
                items.push(lines[i].trim());
                i += 1;
            }
            first = format!("{first} {}", items.join(", "));
        }
        out.push(first);
    }
    out.extend(lines[i..].iter().map(|l| l.to_string()));
    out.iter().map(|l| cubist::error::cap_message(l)).collect::<Vec<_>>().join("\n")
}

/// SIGINT and SIGTERM (the add-on's cancel, a farm's job kill) and SIGHUP remove the temporary
/// files of outputs being written, then exit with 128 + the signal: nothing partial remains.
#[cfg(unix)]
fn handle_signals() {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else { return };
    let _ = std::thread::Builder::new().name("signals".into()).spawn(move || {
        if let Some(sig) = signals.forever().next() {
            cubist::util::files::remove_temporary_files();
            std::process::exit(128 + sig);
        }
    });
}

#[cfg(windows)]
fn handle_signals() {
    let _ = ctrlc::set_handler(|| {
        cubist::util::files::remove_temporary_files();
        std::process::exit(130);
    });
}

#[cfg(not(any(unix, windows)))]
fn handle_signals() {}
