//! `candela`: the command line of the candela renderer.
//!
//! The only place with `anyhow` and exit codes: libraries return typed errors, this binary
//! prints them (`file:line:col: message` for scene errors) and exits non-zero.

mod args;
mod convert;
mod frames;
mod identity;
mod images;
mod merge;
mod parts;
mod progress;
mod run;
mod session;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = args::Cli::parse();
    let result = match cli.command {
        args::Command::Demo(a) => run::demo(a),
        args::Command::Render(a) => run::render(a),
        args::Command::Convert(a) => convert::run(a),
        args::Command::Merge(a) => merge::run(a),
        args::Command::Denoise(a) => images::denoise_command(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.is::<session::Interrupted>() => {
            eprintln!("candela: {e}");
            ExitCode::from(session::EXIT_INTERRUPTED as u8)
        }
        Err(e) => {
            eprintln!("candela: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
