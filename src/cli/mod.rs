//! The subcommands. Each parses nothing itself (clap did) and returns a
//! [`Failure`] with the exit code its error kind deserves.

pub mod accuracy;
pub mod inspect;
pub mod merge;
pub mod run;
pub mod solve;
pub mod stress;

use impactmc::output::OutputError;
use impactmc::study::{message_chain, StudyError};

/// Summary format on stdout.
#[derive(Clone, Copy, clap::ValueEnum)]
pub enum Format {
    Text,
    Json,
}

/// An error with the exit code it deserves: 2 for bad input (the scene, the
/// case, the flags, the output folder), 1 for a failure while running or
/// writing.
pub struct Failure {
    pub code: u8,
    pub message: String,
}

impl Failure {
    pub fn bad_input(message: impl std::fmt::Display) -> Self {
        Self {
            code: 2,
            message: message.to_string(),
        }
    }

    pub fn failed(message: impl std::fmt::Display) -> Self {
        Self {
            code: 1,
            message: message.to_string(),
        }
    }
}

impl From<StudyError> for Failure {
    fn from(e: StudyError) -> Self {
        let message = message_chain(&e);
        if e.is_bad_input() {
            Self::bad_input(message)
        } else {
            Self::failed(message)
        }
    }
}

impl From<OutputError> for Failure {
    /// Writing a folder after the work is done: a failure. (A folder that
    /// cannot be prepared before any work is bad input; the subcommands map
    /// that with [`Failure::bad_input`].)
    fn from(e: OutputError) -> Self {
        Self::failed(message_chain(&e))
    }
}

/// Writes to stdout; a closed pipe (`| head`) ends the program quietly
/// instead of panicking.
pub fn emit(text: &str) {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    if let Err(e) = out.write_all(text.as_bytes()).and_then(|_| out.flush()) {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
        eprintln!("error: stdout: {e}");
        std::process::exit(1);
    }
}

/// Prints a summary after its folder is written: the text (and where it
/// went) or the JSON.
pub fn report(text: &str, json: &serde_json::Value, dir: &std::path::Path, format: Format) {
    match format {
        Format::Text => {
            emit(text);
            emit(&format!("\nwrote {}\n", dir.display()));
        }
        Format::Json => emit(&format!(
            "{}\n",
            serde_json::to_string_pretty(json).expect("summary serialises")
        )),
    }
}
