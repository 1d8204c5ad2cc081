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

/// A count as people write it: `1000000`, `1_000_000` or `1e6` (digits,
/// then optionally `e` and an exponent). Anything else (`1.5e3`, `-5`, a
/// count above 2^64 − 1) is an error that says what a count looks like.
pub fn parse_count(s: &str) -> Result<u64, String> {
    let bad = || format!("{s:?} is not a count: write 1000000, 1_000_000 or 1e6");
    let t = s.trim().replace('_', "");
    let (mantissa, exponent) = match t.split_once(['e', 'E']) {
        Some((m, e)) => (m, e),
        None => (t.as_str(), "0"),
    };
    let digits = |x: &str| !x.is_empty() && x.bytes().all(|b| b.is_ascii_digit());
    if !digits(mantissa) || !digits(exponent) {
        return Err(bad());
    }
    let m: u64 = mantissa.parse().map_err(|_| bad())?;
    let e: u32 = exponent.parse().map_err(|_| bad())?;
    10u64
        .checked_pow(e)
        .and_then(|p| m.checked_mul(p))
        .ok_or_else(bad)
}

/// `--target-ci STAT=EPS`: a statistic's name and the half-width to reach.
pub fn parse_target(s: &str) -> Result<(String, f64), String> {
    let bad = || format!("{s:?} is not STAT=EPS: write energy_ratio=1e-4");
    let (name, eps) = s.split_once('=').ok_or_else(bad)?;
    let name = name.trim();
    if name.is_empty() {
        return Err(bad());
    }
    let eps: f64 = eps.trim().parse().map_err(|_| bad())?;
    Ok((name.to_string(), eps))
}

#[cfg(test)]
mod tests {
    use super::{parse_count, parse_target};

    #[test]
    fn targets_are_a_name_and_a_number() {
        assert_eq!(
            parse_target("energy_ratio=1e-4"),
            Ok(("energy_ratio".into(), 1e-4))
        );
        for bad in ["energy_ratio", "=1e-4", "energy_ratio=small", ""] {
            assert!(parse_target(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn counts_take_underscores_and_exponents() {
        assert_eq!(parse_count("1000000"), Ok(1_000_000));
        assert_eq!(parse_count("1_000"), Ok(1000));
        assert_eq!(parse_count("1e5"), Ok(100_000));
        assert_eq!(parse_count("25E2"), Ok(2500));
        assert_eq!(parse_count("18446744073709551615"), Ok(u64::MAX));
        for bad in ["1.5e3", "-5", "ten", "1e30", "1e", "e5", "", "1e-3"] {
            let e = parse_count(bad).unwrap_err();
            assert!(e.contains("not a count") && e.contains("1e6"), "{bad}: {e}");
        }
    }
}

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
