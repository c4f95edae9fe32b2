//! Exit codes (docs/command-line.md, "Exit status") and the error kinds that choose them, plus
//! printing that never panics (a closed or full standard error is not a reason to crash).

use std::io::Write;
use std::process::ExitCode;

/// Success.
pub const OK: u8 = 0;
/// An input could not be used: a scene, mesh, image or cache file is unreadable, malformed or
/// over a limit, or the render failed.
pub const INPUT: u8 = 1;
/// A usage error: a bad option or combination of options, found before any work.
pub const USAGE: u8 = 2;
/// An output could not be written (nothing was written).
pub const OUTPUT: u8 = 3;

/// A usage error: its message names the option.
#[derive(Debug)]
pub struct Usage(pub String);

impl std::fmt::Display for Usage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Usage {}

/// An output that could not be written.
#[derive(Debug)]
pub struct Output(pub String);

impl std::fmt::Display for Output {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Output {}

/// The exit code of an error: [`USAGE`] or [`OUTPUT`] when one of its causes says so, else
/// [`INPUT`].
pub fn code_of(e: &anyhow::Error) -> u8 {
    for cause in e.chain() {
        if cause.is::<Usage>() {
            return USAGE;
        }
        if cause.is::<Output>() || cause.is::<candela_imageio::atomic::AtomicWriteError>() {
            return OUTPUT;
        }
    }
    INPUT
}

/// Prints a line to standard error, ignoring failures (closed, full).
pub fn eprint_line(args: std::fmt::Arguments<'_>) {
    let _ = writeln!(std::io::stderr().lock(), "{args}");
}

/// Prints `candela: error: …` and returns the exit code for `e`.
pub fn report(e: &anyhow::Error) -> ExitCode {
    eprint_line(format_args!("candela: error: {e:#}"));
    ExitCode::from(code_of(e))
}

/// Makes sure that file descriptors 0, 1 and 2 are open (on `/dev/null` when they were closed),
/// so that no file the program opens takes their place and receives its messages.
pub fn guard_standard_descriptors() {
    use std::os::fd::{AsRawFd, IntoRawFd};
    // `open` returns the lowest free descriptor: while it is one of 0, 1, 2, keep it there.
    for _ in 0..3 {
        match std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open("/dev/null")
        {
            Ok(f) if f.as_raw_fd() <= 2 => {
                let _ = f.into_raw_fd();
            }
            _ => break,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_follow_the_cause() {
        let usage = anyhow::Error::new(Usage("--spp: bad".into())).context("while checking");
        assert_eq!(code_of(&usage), USAGE);
        let out = anyhow::Error::new(Output("x.png: cannot write".into()));
        assert_eq!(code_of(&out), OUTPUT);
        assert_eq!(code_of(&anyhow::anyhow!("scene.txt:1:1: bad")), INPUT);
    }
}
