//! `candela`: the command line of the candela renderer.
//!
//! The only place with `anyhow` and exit codes: libraries return typed errors, this binary
//! prints them (`file:line:col: message` for scene errors) and exits with the status of
//! [`exit`] (0 ok, 1 input error, 2 usage error, 3 output error).

/// `eprintln!` that never panics: a closed or full standard error loses the message, not the
/// run. Defined before the modules so that it replaces the standard macro in all of them.
macro_rules! eprintln {
    ($($arg:tt)*) => {
        $crate::exit::eprint_line(format_args!($($arg)*))
    };
}

mod args;
mod bytes;
mod convert;
mod exit;
mod frames;
mod identity;
mod images;
mod inputs;
mod merge;
mod outputs;
mod parts;
mod preview;
mod progress;
mod run;
mod session;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    exit::guard_standard_descriptors();
    let cli = match args::Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            // Help and version go to standard output with status 0; errors are usage errors.
            let _ = e.print();
            return ExitCode::from(if e.use_stderr() {
                exit::USAGE
            } else {
                exit::OK
            });
        }
    };
    if let Err(e) = inputs::validate(&cli.command) {
        return exit::report(&anyhow::Error::new(e));
    }
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
        Err(e) => exit::report(&e),
    }
}
