//! Every entry of `tests/data/golden/friction_cases.json` and
//! `friction_threshold_cases.json` (friction.md),
//! compared by the rules of `tests/data/golden/README.md`, "Friction": the
//! expected values come from 40-digit mpmath (`mp`), an independent f64
//! DOP853 integration of Darboux–Keller (`ode`) or `cases.json` (`copy`),
//! never from impactmc. Validation entries must be refused with exit
//! status 2 and a message naming what is wrong.

use crate::support;

use impactmc::config::case::{Case, CaseInput, CaseOutput};
use serde::Deserialize;
use support::golden::{compare, finish, Report, Tolerance};

#[derive(Deserialize)]
struct Entry {
    id: String,
    input: serde_json::Value,
    #[serde(default)]
    expected: Option<CaseOutput>,
    #[serde(default)]
    tolerance: Option<Tolerance>,
    #[serde(default)]
    forbidden_flags: Vec<String>,
    #[serde(default)]
    expect_error: bool,
    #[serde(default)]
    error_mentions: Vec<String>,
}

#[derive(Deserialize)]
struct File {
    cases: Vec<Entry>,
}

fn load_file(name: &str) -> File {
    let text = support::data_file(&format!("golden/{name}"));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{name} deserialises: {e}"))
}

fn load() -> File {
    load_file("friction_cases.json")
}

/// The library's answer: the parsed and validated case, solved, or the
/// error message.
fn solve(input: &serde_json::Value) -> Result<CaseOutput, String> {
    let input: CaseInput = serde_json::from_value(input.clone()).map_err(|e| e.to_string())?;
    Case::from_input(&input)
        .and_then(|c| c.solve())
        .map_err(|e| e.to_string())
}

#[test]
fn friction_golden_cases() {
    check_file("friction_cases.json", 297);
}

/// Rods with μ within 1e-5 and 1e-6 of their stick threshold, where the
/// slip falls to zero only asymptotically under `stronge`.
#[test]
fn friction_threshold_golden_cases() {
    check_file("friction_threshold_cases.json", 112);
}

fn check_file(name: &str, entries: usize) {
    let file = load_file(name);
    assert_eq!(file.cases.len(), entries, "entry count of {name}");
    let mut r = Report::default();
    for e in &file.cases {
        let id = e.id.as_str();
        let result = solve(&e.input);
        if e.expect_error {
            match result {
                Ok(_) => r
                    .failures
                    .push(format!("{id}: accepted, expected an error")),
                Err(msg) => {
                    let lower = msg.to_lowercase();
                    for word in &e.error_mentions {
                        r.require(
                            id,
                            lower.contains(&word.to_lowercase()),
                            format!("error {msg:?} does not mention {word:?}"),
                        );
                    }
                }
            }
            continue;
        }
        let got = match result {
            Ok(o) => o,
            Err(err) => {
                r.failures.push(format!("{id}: rejected: {err}"));
                continue;
            }
        };
        let x = e.expected.as_ref().expect("an expected output");
        compare(
            &mut r,
            id,
            &got,
            x,
            e.tolerance.as_ref().expect("tolerances"),
        );
        for flag in &x.flags {
            r.require(
                id,
                got.flags.contains(flag),
                format!("flag {flag} missing (got {:?})", got.flags),
            );
        }
        for flag in &e.forbidden_flags {
            r.require(
                id,
                !got.flags.contains(flag),
                format!("forbidden flag {flag} printed (got {:?})", got.flags),
            );
        }
    }
    finish(&r, name, file.cases.len());
}

/// The validation entries through the binary: exit status 2 and every
/// listed word in the message.
#[test]
fn friction_validation_entries_exit_2_through_the_cli() {
    let file = load();
    let mut checked = 0;
    for e in file.cases.iter().filter(|e| e.expect_error) {
        let dir = support::tmpdir(&format!("friction-{}", e.id.replace('/', "-")));
        let path = dir.join("case.json");
        std::fs::write(&path, e.input.to_string()).unwrap();
        let out = support::bin().arg("solve").arg(&path).output().unwrap();
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stderr),
            String::from_utf8_lossy(&out.stdout)
        )
        .to_lowercase();
        assert_eq!(out.status.code(), Some(2), "{}: {text}", e.id);
        for word in &e.error_mentions {
            assert!(
                text.contains(&word.to_lowercase()),
                "{}: {text:?} lacks {word:?}",
                e.id
            );
        }
        checked += 1;
    }
    assert!(checked >= 6, "only {checked} validation entries");
}
