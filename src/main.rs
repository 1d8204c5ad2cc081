//! The `impactmc` command line. Errors are reported once, here; bad input
//! exits with code 2.

use std::io::Read;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

use impactmc::case::{parse_case, Case};
use impactmc::engine::{Keep, RunOptions, Shard};
use impactmc::output::prepare_dir;
use impactmc::scene::Overrides;
use impactmc::study::{merge_study, run_study, StudyError};
use impactmc::sweep::plan;

/// The scene `impactmc run` uses when given none.
const DEFAULT_SCENE: &str = "configs/corner3.toml";

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
    Run(RunArgs),
    /// Run the hard-case families (stability suite) and print the table.
    Stress {
        /// Samples per case.
        #[arg(long, default_value_t = 4096)]
        samples: usize,
    },
    /// Merge shard folders (written by `run --shard I/N`) into the outputs
    /// of a single run, and print its summary.
    Merge(MergeArgs),
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
        #[arg(long, value_enum, default_value_t = Format::Text)]
        format: Format,
    },
}

#[derive(clap::Args)]
struct RunArgs {
    /// Scene file (TOML). Default: configs/corner3.toml.
    scene: Option<PathBuf>,
    /// Number of samples (overrides the scene's `samples`).
    #[arg(long)]
    samples: Option<u64>,
    /// Random seed (overrides the scene's `seed`).
    #[arg(long)]
    seed: Option<u64>,
    /// Worker threads (default: all cores). Results do not depend on it.
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Impact law: paper, newton, poisson or pgsN. Repeatable; replaces the
    /// scene's `laws`.
    #[arg(long = "law")]
    laws: Vec<String>,
    /// Kernel precision: f32 or f64 (overrides the scene's `precision`).
    #[arg(long)]
    precision: Option<String>,
    /// Output folder (default: results/<scene name>/).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Overwrite an output folder that already holds a run.
    #[arg(long)]
    force: bool,
    /// Also write samples.parquet, one row per sample (streamed).
    #[arg(long)]
    per_sample: bool,
    /// Per-sample columns to keep, comma-separated (default: all).
    #[arg(long, value_delimiter = ',')]
    columns: Option<Vec<String>>,
    /// Run only shard I of N (0 ≤ I < N): a contiguous share of the batches,
    /// saved with its accumulator state for `impactmc merge`.
    #[arg(long, value_name = "I/N")]
    shard: Option<String>,
    /// Statistics with quantiles (p01, median, p99) and histograms,
    /// comma-separated: energy_ratio, omega_after_norm,
    /// velocity_after_norm, impulse, rebound. Replaces the scene's
    /// `[statistics] quantiles` (default: energy_ratio); `--quantiles ''`
    /// keeps none (moments only).
    #[arg(long, value_delimiter = ',', value_name = "STATS")]
    quantiles: Option<Vec<String>>,
    /// Summary format on stdout.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    format: Format,
    /// Keep computing effects the scene does not need: rotation, lcp,
    /// statistics or all (comma-separated or repeated). Same answers,
    /// slower: for measuring what compiling an effect out saves.
    #[arg(long, value_delimiter = ',')]
    keep: Vec<String>,
    /// Same as `--keep all`.
    #[arg(long)]
    all_effects: bool,
}

#[derive(clap::Args)]
struct MergeArgs {
    /// Shard folders, in any order.
    #[arg(required = true)]
    shards: Vec<PathBuf>,
    /// Output folder for the merged run.
    #[arg(long)]
    out: PathBuf,
    /// Overwrite an output folder that already holds a run.
    #[arg(long)]
    force: bool,
    /// Merge even if shards are missing (the result is marked partial) or
    /// given twice (the first copy is kept).
    #[arg(long)]
    allow_partial: bool,
    /// Summary format on stdout.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    format: Format,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum Format {
    Text,
    Json,
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
    emit(&format!("{json}\n"));
    Ok(())
}

/// Writes to stdout; a closed pipe (`| head`) ends the program quietly
/// instead of panicking.
fn emit(text: &str) {
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

fn run_scene(args: &RunArgs) -> Result<(), Failure> {
    let path = args
        .scene
        .clone()
        .unwrap_or_else(|| PathBuf::from(DEFAULT_SCENE));
    let overrides = Overrides {
        per_sample: args.per_sample,
        columns: args.columns.clone(),
        samples: args.samples,
        seed: args.seed,
        laws: (!args.laws.is_empty()).then(|| args.laws.clone()),
        precision: args.precision.clone(),
        // `--quantiles ''` is the empty list, as `quantiles = []` is.
        quantiles: args
            .quantiles
            .clone()
            .map(|q| if q == [""] { Vec::new() } else { q }),
    };
    let shard = args
        .shard
        .as_deref()
        .map(Shard::parse)
        .transpose()
        .map_err(bad_input)?;
    // Validate the scene (every sweep point) and the folder before any work.
    let (_, points) = plan(&path, &overrides).map_err(|e| bad_input(e.to_string()))?;
    let name = points[0].scene.name().to_string();
    // The effect set, before any work (stderr: stdout may be JSON).
    eprintln!("{}", points[0].scene.effects().line());
    let mut keep = if args.all_effects {
        Keep::ALL
    } else {
        Keep::NONE
    };
    for k in &args.keep {
        keep = keep.with(k).map_err(bad_input)?;
    }

    if points[0].scene.drop_box().is_some() {
        if points.len() > 1 || shard.is_some() || points[0].scene.effects().per_sample {
            return Err(bad_input(format!(
                "{}: drop scenes (placement.drop) do not support sweeps, --shard or per-sample rows yet",
                path.display()
            )));
        }
        let dir = args
            .out
            .clone()
            .unwrap_or_else(|| PathBuf::from("results").join(&name));
        prepare_dir(&dir, args.force).map_err(|e| bad_input(e.to_string()))?;
        let scene = &points[0].scene;
        let started = std::time::SystemTime::now();
        let run = impactmc::drop::run_drop(scene, args.threads).map_err(|e| Failure {
            code: 1,
            message: e.to_string(),
        })?;
        impactmc::drop::write_outputs(&run, scene, &dir, started).map_err(|e| Failure {
            code: 1,
            message: e.to_string(),
        })?;
        match args.format {
            Format::Text => {
                emit(&run.text(scene));
                emit(&format!("\nwrote {}\n", dir.display()));
            }
            Format::Json => emit(&format!(
                "{}\n",
                serde_json::to_string_pretty(&run.summary_json(scene)).expect("serialisable")
            )),
        }
        return Ok(());
    }
    let variant = impactmc::engine::KernelVariant::of(&points[0].scene, keep);
    eprintln!(
        "kernel: {}{}",
        variant.name(),
        if keep == Keep::NONE {
            String::new()
        } else {
            format!(" (kept although not needed: {keep:?})")
        }
    );
    let dir = args.out.clone().unwrap_or_else(|| match shard {
        Some(s) => {
            PathBuf::from("results").join(format!("{name}-shard-{}-of-{}", s.index, s.count))
        }
        None => PathBuf::from("results").join(&name),
    });
    prepare_dir(&dir, args.force).map_err(|e| bad_input(e.to_string()))?;
    let study = run_study(
        &path,
        &overrides,
        &RunOptions {
            threads: args.threads,
            progress: true,
            shard,
            keep,
        },
        &dir,
    )
    .map_err(|e| match e {
        StudyError::Scene(e) => bad_input(e.to_string()),
        other => Failure {
            code: 1,
            message: other.to_string(),
        },
    })?;
    let mut text = study.text();
    if let Some(s) = shard {
        let r = &study.points[0].result;
        let range = s.batches(r.batches);
        text = format!(
            "shard {}/{}: batches {}..{} of {} per point (merge the shard folders with `impactmc merge`)\n{text}",
            s.index, s.count, range.start, range.end, r.batches
        );
    }
    finish(study, text, &dir, args.format)
}

/// Writes a study's folder, then prints its summary.
fn finish(
    study: impactmc::study::Study,
    text: String,
    dir: &std::path::Path,
    format: Format,
) -> Result<(), Failure> {
    let json = study.summary_json();
    // Outputs first, so a closed stdout never costs the results.
    study.write().map_err(|e| Failure {
        code: 1,
        message: e.to_string(),
    })?;
    match format {
        Format::Text => {
            emit(&text);
            emit(&format!("\nwrote {}\n", dir.display()));
        }
        Format::Json => emit(&format!(
            "{}\n",
            serde_json::to_string_pretty(&json).expect("summary serialises")
        )),
    }
    Ok(())
}

fn merge(args: &MergeArgs) -> Result<(), Failure> {
    prepare_dir(&args.out, args.force).map_err(|e| bad_input(e.to_string()))?;
    let study = merge_study(&args.shards, args.allow_partial, &args.out).map_err(|e| match e {
        StudyError::Scene(e) => bad_input(e.to_string()),
        StudyError::Merge(e) => bad_input(e.to_string()),
        other => Failure {
            code: 1,
            message: other.to_string(),
        },
    })?;
    let mut text = study.text();
    if let Some(m) = &study.merge {
        let mut head = format!(
            "merged {} of {} shards",
            m.shards_merged.len(),
            m.shard_count
        );
        if m.partial {
            head.push_str(&format!(
                "; PARTIAL: shards {:?} are missing, so the statistics cover only the merged shards' samples",
                m.missing_shards
            ));
        }
        if !m.duplicate_shards_ignored.is_empty() {
            head.push_str(&format!(
                "; duplicate copies of shards {:?} ignored",
                m.duplicate_shards_ignored
            ));
        }
        text = format!("{head}\n{text}");
    }
    finish(study, text, &args.out, args.format)
}

fn accuracy(scene: &Option<PathBuf>, out: &Option<PathBuf>, force: bool) -> Result<(), Failure> {
    let path = scene
        .clone()
        .unwrap_or_else(|| PathBuf::from("configs/accuracy_corner3.toml"));
    let base = impactmc::scene::load_scene(&path, &Default::default())
        .map_err(|e| bad_input(e.to_string()))?;
    impactmc::accuracy::Knobs::from_raw(&path.display().to_string(), base.raw())
        .map_err(|e| bad_input(e.to_string()))?;
    let dir = out
        .clone()
        .unwrap_or_else(|| PathBuf::from("results").join(format!("{}-accuracy", base.name())));
    prepare_dir(&dir, force).map_err(|e| bad_input(e.to_string()))?;
    let fail = |m: String| Failure {
        code: 1,
        message: m,
    };
    let ladder = impactmc::accuracy::ladder(&path, &mut |line| eprintln!("{line}"))
        .map_err(|e| bad_input(e.to_string()))?;
    let machine = impactmc::manifest::Machine::current();
    let header = format!(
        "Regenerate with `cargo run --release -- accuracy {} --out {} --force`. Machine: {} ({} logical cores, {}). Date: {}. impactmc {} ({}).",
        path.display(),
        dir.display(),
        machine.cpu,
        machine.logical_cores,
        machine.os,
        &impactmc::manifest::utc_string(std::time::SystemTime::now())[..10],
        env!("CARGO_PKG_VERSION"),
        env!("IMPACTMC_GIT_COMMIT"),
    );
    let md = ladder.markdown(&header);
    let svg = impactmc::accuracy::plot_svg(&ladder).map_err(fail)?;
    let mut df = ladder.frame().map_err(|e| fail(e.to_string()))?;
    let mut staging = impactmc::output::Staging::new(&dir);
    let io = |e: impactmc::output::OutputError| Failure {
        code: 1,
        message: e.to_string(),
    };
    impactmc::output::write_parquet(
        &mut staging,
        "accuracy.parquet",
        &mut df,
        impactmc::output::schema_metadata(),
    )
    .map_err(io)?;
    for (name, text) in [("accuracy.md", &md), ("accuracy.svg", &svg)] {
        let target = dir.join(name).display().to_string();
        staging
            .write(name, |f| {
                use std::io::Write;
                f.write_all(text.as_bytes())
                    .map_err(|source| impactmc::output::OutputError::Io {
                        path: target.clone(),
                        source,
                    })
            })
            .map_err(io)?;
    }
    staging.commit().map_err(io)?;
    emit(&md);
    emit(&format!("\nwrote {}\n", dir.display()));
    Ok(())
}

fn inspect(dir: &std::path::Path, format: Format) -> Result<(), Failure> {
    let read = |name: &str| -> Result<serde_json::Value, Failure> {
        let path = dir.join(name);
        let text = std::fs::read_to_string(&path).map_err(|e| {
            bad_input(format!(
                "{}: {e} (not a finished impactmc run folder: manifest.json is written last)",
                path.display()
            ))
        })?;
        serde_json::from_str(&text).map_err(|e| bad_input(format!("{}: {e}", path.display())))
    };
    let manifest = read("manifest.json")?;
    let summary = read("summary.json")?;
    match format {
        Format::Json => emit(&format!(
            "{}\n",
            serde_json::to_string_pretty(
                &serde_json::json!({"manifest": manifest, "summary": summary})
            )
            .expect("serialisable")
        )),
        Format::Text => {
            let m = &manifest;
            emit(&format!(
                "run folder {}\n  scene {} (seed {}, {} samples per point, {} point(s))\n  impactmc {} ({}), schema {}\n  started {}, finished {}, wall {:.3} s, {} threads on {} ({})\n  files: {}\n",
                dir.display(),
                m["scene"]["name"].as_str().unwrap_or("?"),
                m["seed"],
                m["samples"],
                m["points"],
                m["impactmc_version"].as_str().unwrap_or("?"),
                m["git_commit"].as_str().unwrap_or("?"),
                m["schema_version"],
                m["started_utc"].as_str().unwrap_or("?"),
                m["finished_utc"].as_str().unwrap_or("?"),
                m["wall_seconds"].as_f64().unwrap_or(f64::NAN),
                m["threads"],
                m["machine"]["cpu"].as_str().unwrap_or("?"),
                m["machine"]["hostname"].as_str().unwrap_or("?"),
                m["files"].as_array().map(|f| f.iter().filter_map(|x| x.as_str()).collect::<Vec<_>>().join(", ")).unwrap_or_default(),
            ));
            if summary["effects"]["flight"] == serde_json::Value::Bool(true) {
                // A drop study: its summary has its own shape (per bounce).
                emit(&format!(
                    "\n{}\n",
                    serde_json::to_string_pretty(&summary).expect("serialisable")
                ));
                return Ok(());
            }
            let summaries: Vec<(String, impactmc::summary::Summary)> = match summary.get("points") {
                Some(points) => points
                    .as_array()
                    .into_iter()
                    .flatten()
                    .filter_map(|p| {
                        let s = serde_json::from_value(p["summary"].clone()).ok()?;
                        Some((format!("\n=== sweep point {} ===\n", p["values"]), s))
                    })
                    .collect(),
                None => serde_json::from_value(summary.clone())
                    .map(|s| vec![(String::from("\n"), s)])
                    .map_err(|e| bad_input(format!("summary.json: {e}")))?,
            };
            for (head, s) in summaries {
                emit(&head);
                emit(&s.to_text());
            }
        }
    }
    Ok(())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Solve { case } => solve(case),
        Command::Run(args) => run_scene(args),
        Command::Merge(args) => merge(args),
        Command::Accuracy { scene, out, force } => accuracy(scene, out, *force),
        Command::Inspect { dir, format } => inspect(dir, *format),
        Command::Stress { samples } => {
            let rows = impactmc::stress::run(*samples);
            emit(&impactmc::stress::table(&rows));
            let bad = rows.iter().filter(|r| !r.within_bound()).count();
            emit(&format!(
                "\n{} rows, {} beyond their bound; matrix → Bryan → matrix worst error near θ = ±90°: {:.1e}\n",
                rows.len(),
                bad,
                impactmc::stress::gimbal_round_trip_error()
            ));
            if bad > 0 {
                Err(Failure {
                    code: 1,
                    message: format!("{bad} stress rows beyond their bound"),
                })
            } else {
                Ok(())
            }
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            eprintln!("error: {}", f.message);
            ExitCode::from(f.code)
        }
    }
}
