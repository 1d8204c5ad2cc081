//! The `impactmc` command line. Errors are reported once, here; bad input
//! exits with code 2.

use std::io::Read;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

use impactmc::case::{parse_case, Case};

#[derive(Parser)]
#[command(
    name = "impactmc",
    version,
    about = "Statistics of rigid-ellipsoid impacts on planes"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Solve one impact case (JSON or TOML file, or - for stdin) and print
    /// the result as JSON.
    Solve {
        /// Case file (.json or .toml), or - to read stdin.
        case: PathBuf,
    },
}

/// An error with the exit code it deserves: 2 for bad input, 1 otherwise.
struct Failure {
    code: u8,
    message: String,
}

fn bad_input(message: impl Into<String>) -> Failure {
    Failure {
        code: 2,
        message: message.into(),
    }
}

fn solve(path: &PathBuf) -> Result<(), Failure> {
    let (text, json, name) = if path.as_os_str() == "-" {
        let mut s = String::new();
        std::io::stdin()
            .read_to_string(&mut s)
            .map_err(|e| bad_input(format!("stdin: {e}")))?;
        (s, None, "stdin".to_string())
    } else {
        let s = std::fs::read_to_string(path)
            .map_err(|e| bad_input(format!("{}: {e}", path.display())))?;
        let json = match path.extension().and_then(|e| e.to_str()) {
            Some("json") => Some(true),
            Some("toml") => Some(false),
            _ => None,
        };
        (s, json, path.display().to_string())
    };
    let input = parse_case(&text, json).map_err(|e| bad_input(format!("{name}: {e}")))?;
    let case = Case::from_input(&input).map_err(|e| bad_input(format!("{name}: {e}")))?;
    let out = case
        .solve()
        .map_err(|e| bad_input(format!("{name}: {e}")))?;
    let json = serde_json::to_string_pretty(&out).map_err(|e| Failure {
        code: 1,
        message: e.to_string(),
    })?;
    println!("{json}");
    Ok(())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Solve { case } => solve(case),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            eprintln!("error: {}", f.message);
            ExitCode::from(f.code)
        }
    }
}
