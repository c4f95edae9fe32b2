//! `candela`: the command line of the candela renderer.
//!
//! The only place with `anyhow` and exit codes: libraries return typed errors, this binary
//! prints them (`file:line:col: message` for scene errors) and exits non-zero.

mod args;
mod convert;
mod run;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = args::Cli::parse();
    let result = match cli.command {
        args::Command::Demo(a) => run::demo(a),
        args::Command::Render(a) => run::render(a),
        args::Command::Convert(a) => convert::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("candela: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
