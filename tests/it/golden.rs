//! Every entry of `tests/data/golden/cases.json`, compared by the rules of
//! `tests/data/golden/README.md`. The expected values were computed outside
//! impactmc in 40-digit arithmetic. Also: the copies of the golden files in
//! the repository are those the maintainers keep.

use crate::support;

use impactmc::config::case::{Case, CaseInput, CaseOutput};
use serde::Deserialize;
use support::golden::{compare, finish, Report, Tolerance};

#[derive(Deserialize)]
struct Entry {
    id: String,
    input: CaseInput,
    expected: CaseOutput,
    tolerance: Tolerance,
}

#[derive(Deserialize)]
struct File {
    cases: Vec<Entry>,
}

#[test]
fn golden_cases_all_laws() {
    let text = support::data_file("golden/cases.json");
    let file: File =
        serde_json::from_str(&text).expect("cases.json deserialises into the public types");
    assert_eq!(file.cases.len(), 1680, "entry count of cases.json");
    let mut r = Report::default();
    for e in &file.cases {
        let id = e.id.as_str();
        let got = match Case::from_input(&e.input).and_then(|c| c.solve()) {
            Ok(o) => o,
            Err(err) => {
                r.failures.push(format!("{id}: rejected: {err}"));
                continue;
            }
        };
        let x = &e.expected;
        compare(&mut r, id, &got, x, &e.tolerance);
        for flag in &x.flags {
            r.require(
                id,
                got.flags.contains(flag),
                format!("flag {flag} missing (got {:?})", got.flags),
            );
        }
    }
    finish(&r, "golden", file.cases.len());
}

/// The golden files carried in `tests/data/golden/` are byte for byte the
/// maintainers' copies, where `IMPACTMC_SHARED` points at them. Skipped
/// without it (a user's clone), unless `IMPACTMC_REQUIRE_SHARED` is set, as
/// `.ci/run` sets both.
#[test]
fn copies_match_the_maintained_golden_files() {
    let dir = support::maintained_golden_dir();
    if !support::available_or_skip(
        dir.is_some(),
        "IMPACTMC_REQUIRE_SHARED",
        "the maintained golden files",
        "IMPACTMC_SHARED names the folder that holds golden/",
    ) {
        return;
    }
    let dir = dir.unwrap();
    for name in [
        "cases.json",
        "friction_cases.json",
        "friction_threshold_cases.json",
        "floor_stats.json",
    ] {
        let ours = support::data_file(&format!("golden/{name}"));
        let theirs = std::fs::read_to_string(dir.join(name))
            .unwrap_or_else(|e| panic!("{}: {e}", dir.join(name).display()));
        assert!(
            ours == theirs,
            "tests/data/golden/{name} differs from {} ({} and {} bytes): copy the maintained file on purpose",
            dir.join(name).display(),
            ours.len(),
            theirs.len()
        );
    }
}
