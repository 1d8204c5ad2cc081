//! `impactmc run`: a scene's study, with the engine the scene calls for.

use std::path::PathBuf;

use impactmc::config::{Keep, Overrides, Precision, SceneText};
use impactmc::engine::RunOptions;
use impactmc::output::prepare_dir;
use impactmc::stats::tree::Shard;
use impactmc::study;

use super::{report, Failure, Format};

/// The scene `impactmc run` uses when given none: built into the binary,
/// so it runs from any folder.
const DEFAULT_SCENE: &str = include_str!("../../configs/corner3.toml");
/// The name errors give the built-in scene.
const DEFAULT_SCENE_NAME: &str = "configs/corner3.toml (built in)";

#[derive(clap::Args)]
pub struct RunArgs {
    /// Scene file (TOML). Default: configs/corner3.toml, built into the
    /// binary.
    scene: Option<PathBuf>,
    /// Number of samples (overrides the scene's `samples`): 1000000,
    /// 1_000_000 or 1e6.
    #[arg(long, value_parser = super::parse_count)]
    samples: Option<u64>,
    /// Random seed (overrides the scene's `seed`).
    #[arg(long)]
    seed: Option<u64>,
    /// Worker threads (default: all cores). Results do not depend on it.
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Impact law: paper, newton, poisson, pgsN or stronge. Repeatable;
    /// replaces the scene's `laws`.
    #[arg(long = "law")]
    laws: Vec<String>,
    /// Kernel precision: f32 or f64 (overrides the scene's `precision`).
    #[arg(long)]
    precision: Option<Precision>,
    /// Sampling method: mc (independent draws) or rqmc (replicates of
    /// Owen-scrambled Sobol points; intervals from their spread).
    /// Overrides the scene's `sampling`.
    #[arg(long, value_name = "mc|rqmc")]
    sampling: Option<String>,
    /// RQMC replicates, 2 to 2^20 (default 16; overrides the scene's
    /// `replicates`).
    #[arg(long, value_name = "R")]
    replicates: Option<u64>,
    /// Output folder (default: results/<scene name>/).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Overwrite an output folder that already holds a run (the files its manifest lists and this run does not write are removed).
    #[arg(long)]
    force: bool,
    /// Also write samples.parquet, one row per sample (a drop scene: per
    /// sample, law and impact; streamed).
    #[arg(long)]
    per_sample: bool,
    /// Per-sample columns to keep, comma-separated (default: all).
    #[arg(long, value_delimiter = ',')]
    columns: Option<Vec<String>>,
    /// Run only shard I of N (0 ≤ I < N): a contiguous share of the batches,
    /// saved with its accumulator state for `impactmc merge`.
    #[arg(long, value_name = "I/N")]
    shard: Option<Shard>,
    /// Statistics with quantiles (p01, median, p99) and histograms,
    /// comma-separated: energy_ratio, omega_after_norm,
    /// velocity_after_norm, impulse, rebound. Replaces the scene's
    /// `[statistics] quantiles` (default: energy_ratio); `--quantiles ''`
    /// keeps none (moments only).
    #[arg(long, value_delimiter = ',', value_name = "STATS")]
    quantiles: Option<Vec<String>>,
    /// A precision to reach, STAT=EPS (repeatable): the run grows its
    /// sample count in rounds until the 95 % half-width of STAT (a
    /// statistic or fraction of the summary, e.g. energy_ratio=1e-4) is at
    /// most EPS under every law. Replaces the scene's `[target] ci95`.
    #[arg(long = "target-ci", value_name = "STAT=EPS", value_parser = super::parse_target)]
    target_ci: Vec<(String, f64)>,
    /// The most samples a target run may take (default 2^32): 1e8 or
    /// 100_000_000.
    #[arg(long, value_parser = super::parse_count)]
    max_samples: Option<u64>,
    /// Summary format on stdout.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    format: Format,
    /// Keep computing effects the scene does not need: rotation, lcp,
    /// statistics, friction or all (comma-separated or repeated; all is
    /// every effect but friction). Same answers, slower: for measuring what
    /// compiling an effect out saves.
    #[arg(long, value_delimiter = ',')]
    keep: Vec<Keep>,
    /// Same as `--keep all`.
    #[arg(long)]
    all_effects: bool,
}

pub fn run(args: &RunArgs) -> Result<(), Failure> {
    let overrides = Overrides {
        per_sample: args.per_sample,
        columns: args.columns.clone(),
        samples: args.samples,
        seed: args.seed,
        laws: (!args.laws.is_empty()).then(|| args.laws.clone()),
        precision: args.precision,
        sampling: args.sampling.clone(),
        replicates: args.replicates,
        // `--quantiles ''` is the empty list, as `quantiles = []` is.
        quantiles: args
            .quantiles
            .clone()
            .map(|q| if q == [""] { Vec::new() } else { q }),
        target_ci: (!args.target_ci.is_empty()).then(|| args.target_ci.clone()),
        max_samples: args.max_samples,
    };
    let keep = args.keep.iter().fold(
        if args.all_effects {
            Keep::ALL
        } else {
            Keep::NONE
        },
        |k, e| k.union(*e),
    );
    let opts = RunOptions {
        threads: args.threads,
        progress: true,
        shard: args.shard,
        keep,
        ..Default::default()
    };
    // Validate the scene (every sweep point) and the folder before any work;
    // what will run goes to stderr (stdout may be JSON).
    let src = match &args.scene {
        Some(path) => SceneText::read(path).map_err(Failure::bad_input)?,
        None => SceneText::new(DEFAULT_SCENE_NAME, DEFAULT_SCENE),
    };
    let prepared = study::prepare(&src, &overrides, &opts)?;
    eprintln!("{}", prepared.effects_line);
    eprintln!("{}", prepared.kernel_line);
    let name = &prepared.name;
    let dir = args.out.clone().unwrap_or_else(|| match args.shard {
        Some(s) => {
            PathBuf::from("results").join(format!("{name}-shard-{}-of-{}", s.index, s.count))
        }
        None => PathBuf::from("results").join(name),
    });
    prepare_dir(&dir, args.force).map_err(Failure::bad_input)?;
    let mut study = study::run(&src, &overrides, &opts, Some(&dir))?;
    let mut text = study.text();
    if let Some(s) = args.shard {
        let r = &study.points[0].result;
        let range = s.batches(r.batches);
        text = format!(
            "shard {}/{}: batches {}..{} of {} per point (merge the shard folders with `impactmc merge`)\n{text}",
            s.index, s.count, range.start, range.end, r.batches
        );
    }
    let json = study.summary_json();
    // Outputs first, so a closed stdout never costs the results.
    study.write()?;
    report(&text, &json, &dir, args.format);
    Ok(())
}
