//! `impactmc merge`: shard folders into the outputs of a single run.

use std::path::PathBuf;

use impactmc::output::prepare_dir;
use impactmc::study::merge_study;

use super::{report, Failure, Format};

#[derive(clap::Args)]
pub struct MergeArgs {
    /// Shard folders, in any order.
    #[arg(required = true)]
    shards: Vec<PathBuf>,
    /// Output folder for the merged run.
    #[arg(long)]
    out: PathBuf,
    /// Overwrite an output folder that already holds a run (the files its manifest lists and this run does not write are removed).
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

pub fn run(args: &MergeArgs) -> Result<(), Failure> {
    prepare_dir(&args.out, args.force).map_err(Failure::bad_input)?;
    let mut study = merge_study(&args.shards, args.allow_partial, &args.out, None)?;
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
    let json = study.summary_json();
    study.write()?;
    report(&text, &json, &args.out, args.format);
    Ok(())
}
