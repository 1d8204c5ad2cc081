//! `impactmc inspect`: a finished run folder's manifest and summary.

use std::path::Path;

use impactmc::output::manifest::ManifestHead;
use impactmc::output::summary::Summary;

use super::{emit, Failure, Format};

fn read(dir: &Path, name: &str) -> Result<serde_json::Value, Failure> {
    let path = dir.join(name);
    let text = std::fs::read_to_string(&path).map_err(|e| {
        Failure::bad_input(format!(
            "{}: {e} (not a finished impactmc run folder: manifest.json is written last)",
            path.display()
        ))
    })?;
    serde_json::from_str(&text).map_err(|e| Failure::bad_input(format!("{}: {e}", path.display())))
}

pub fn run(dir: &Path, format: Format) -> Result<(), Failure> {
    let manifest = read(dir, "manifest.json")?;
    let summary = read(dir, "summary.json")?;
    if let Format::Json = format {
        let both = serde_json::json!({"manifest": manifest, "summary": summary});
        emit(&format!(
            "{}\n",
            serde_json::to_string_pretty(&both).expect("serialisable")
        ));
        return Ok(());
    }
    let head: ManifestHead = serde_json::from_value(manifest)
        .map_err(|e| Failure::bad_input(format!("{}: {e}", dir.join("manifest.json").display())))?;
    emit(&head.text(dir));
    let bad_summary = |e: serde_json::Error| Failure::bad_input(format!("summary.json: {e}"));
    let summaries: Vec<(String, Summary)> = match summary.get("points").and_then(|p| p.as_array()) {
        Some(points) => points
            .iter()
            .map(|p| {
                let s = serde_json::from_value(p["summary"].clone()).map_err(bad_summary)?;
                Ok((format!("\n=== sweep point {} ===\n", p["values"]), s))
            })
            .collect::<Result<_, Failure>>()?,
        None => vec![(
            String::from("\n"),
            serde_json::from_value(summary).map_err(bad_summary)?,
        )],
    };
    for (head, s) in summaries {
        emit(&head);
        emit(&s.to_text());
    }
    Ok(())
}
