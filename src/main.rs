//! The `impactmc` command line: parses the arguments, runs the subcommand
//! and reports its one error with the exit code its kind deserves (2 for
//! bad input, 1 for a failure).

mod cli;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

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
    /// Run a scene's Monte Carlo study, print its summary and write the
    /// results folder.
    Run(Box<cli::run::RunArgs>),
    /// Run the hard-case families (stability suite) and print the table.
    Stress {
        /// Samples per case.
        #[arg(long, default_value_t = 4096)]
        samples: usize,
    },
    /// Merge shard folders (written by `run --shard I/N`) into the outputs
    /// of a single run, and print its summary.
    Merge(cli::merge::MergeArgs),
    /// The accuracy ladder of a scene: what each law, solver setting,
    /// precision, contact-point route and sample count costs and buys.
    /// Writes accuracy.parquet, accuracy.md and accuracy.svg.
    Accuracy {
        /// Scene file with [accuracy] and [material] knobs. Default:
        /// configs/accuracy_corner3.toml.
        scene: Option<PathBuf>,
        /// Output folder (default: results/<scene name>-accuracy/).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Overwrite an output folder that already holds results.
        #[arg(long)]
        force: bool,
    },
    /// Print the manifest and summary of a finished run folder.
    Inspect {
        /// A folder written by `impactmc run`.
        dir: PathBuf,
        /// Output format.
        #[arg(long, value_enum, default_value_t = cli::Format::Text)]
        format: cli::Format,
    },
}

fn main() -> ExitCode {
    let result = match Cli::parse().command {
        Command::Solve { case } => cli::solve::run(&case),
        Command::Run(args) => cli::run::run(&args),
        Command::Merge(args) => cli::merge::run(&args),
        Command::Accuracy { scene, out, force } => {
            cli::accuracy::run(scene.as_deref(), out.as_deref(), force)
        }
        Command::Inspect { dir, format } => cli::inspect::run(&dir, format),
        Command::Stress { samples } => cli::stress::run(samples),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            eprintln!("error: {}", f.message);
            ExitCode::from(f.code)
        }
    }
}
