//! `impactmc solve`: one impact case, as JSON.

use std::io::Read;
use std::path::Path;

use impactmc::config::case::solve_text;

use super::{emit, Failure};

pub fn run(path: &Path) -> Result<(), Failure> {
    let (text, json, name) = if path.as_os_str() == "-" {
        let mut s = String::new();
        std::io::stdin()
            .read_to_string(&mut s)
            .map_err(|e| Failure::bad_input(format!("stdin: {e}")))?;
        (s, None, "stdin".to_string())
    } else {
        let s = std::fs::read_to_string(path)
            .map_err(|e| Failure::bad_input(format!("{}: {e}", path.display())))?;
        let json = match path.extension().and_then(|e| e.to_str()) {
            Some("json") => Some(true),
            Some("toml") => Some(false),
            _ => None,
        };
        (s, json, path.display().to_string())
    };
    let out = solve_text(&name, &text, json).map_err(Failure::bad_input)?;
    let json = serde_json::to_string_pretty(&out).map_err(Failure::failed)?;
    emit(&format!("{json}\n"));
    Ok(())
}
