//! `impactmc inspect`: a finished run folder's manifest and summary.

use std::path::Path;

use impactmc::output::manifest::inspect;

use super::{emit, Failure, Format};

pub fn run(dir: &Path, format: Format) -> Result<(), Failure> {
    let seen = inspect(dir).map_err(Failure::bad_input)?;
    match format {
        Format::Json => {
            let both = serde_json::json!({"manifest": seen.manifest, "summary": seen.summary});
            emit(&format!(
                "{}\n",
                serde_json::to_string_pretty(&both).expect("serialisable")
            ));
        }
        Format::Text => emit(&seen.text),
    }
    Ok(())
}
