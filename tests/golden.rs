//! Every entry of `shared/golden/cases.json`, compared by the rules of
//! `shared/golden/README.md`. The expected values were computed outside
//! impactmc in 40-digit arithmetic.

mod support;

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
    let text = support::shared_file("golden/cases.json");
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
