//! Malformed and extreme case and scene files: property tests that
//! mutate valid inputs (numbers replaced by extreme or non-finite values,
//! fields dropped, duplicated or renamed, text truncated) and require that
//! parsing, validation and solving never panic, and that every rejection is
//! one message naming a field or a parse position.

use crate::support;

use std::panic::{catch_unwind, AssertUnwindSafe};

use impactmc::config::case::{parse_case, Case};
use impactmc::config::Scene;
use impactmc::engine::{run as run_scene, RunOptions};
use proptest::prelude::*;
use support::scenes::run;

const CASE: &str = include_str!("../../configs/paper_example.json");
const SCENE: &str = include_str!("../../configs/corner3.toml");

/// Extreme replacements for a number.
const EXTREMES: [&str; 12] = [
    "0",
    "-0.0",
    "-1",
    "1e308",
    "-1e308",
    "1e-320",
    "5e-324",
    "1e20",
    "-1e-20",
    "123456789012345678901234567890",
    "0.5",
    "2",
];
const TOML_ONLY: [&str; 3] = ["nan", "inf", "-inf"];

#[derive(Debug, Clone)]
enum Mutation {
    /// Replace the k-th number with extreme value e.
    Number(usize, usize),
    /// Drop the line holding the k-th number.
    DropLine(usize),
    /// Duplicate a line.
    DupLine(usize),
    /// Truncate at a fraction of the text.
    Truncate(u8),
    /// Rename a key by appending "x".
    RenameKey(usize),
}

fn mutation() -> impl Strategy<Value = Vec<Mutation>> {
    let one = prop_oneof![
        4 => (0usize..64, 0usize..15).prop_map(|(k, e)| Mutation::Number(k, e)),
        1 => (0usize..64).prop_map(Mutation::DropLine),
        1 => (0usize..64).prop_map(Mutation::DupLine),
        1 => (1u8..100).prop_map(Mutation::Truncate),
        1 => (0usize..64).prop_map(Mutation::RenameKey),
    ];
    prop::collection::vec(one, 1..4)
}

/// Byte ranges of the numbers in a text.
fn numbers(text: &str) -> Vec<(usize, usize)> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let starts = (b[i].is_ascii_digit() || b[i] == b'-')
            && (i == 0 || !b[i - 1].is_ascii_alphanumeric() && b[i - 1] != b'_');
        if starts {
            let j = (i + 1..b.len())
                .find(|&j| {
                    !(b[j].is_ascii_digit()
                        || matches!(b[j], b'.' | b'e' | b'E' | b'-' | b'+' | b'_'))
                })
                .unwrap_or(b.len());
            if text[i..j].chars().any(|c| c.is_ascii_digit()) {
                out.push((i, j));
            }
            i = j;
        } else {
            i += 1;
        }
    }
    out
}

fn apply(text: &str, muts: &[Mutation], toml: bool) -> String {
    let mut t = text.to_string();
    for m in muts {
        match *m {
            Mutation::Number(k, e) => {
                let nums = numbers(&t);
                if nums.is_empty() {
                    continue;
                }
                let (a, b) = nums[k % nums.len()];
                let pool: Vec<&str> = EXTREMES
                    .iter()
                    .chain(if toml { TOML_ONLY.iter() } else { [].iter() })
                    .copied()
                    .collect();
                t.replace_range(a..b, pool[e % pool.len()]);
            }
            Mutation::DropLine(k) | Mutation::DupLine(k) => {
                let mut lines: Vec<String> = t.lines().map(String::from).collect();
                if lines.is_empty() {
                    continue;
                }
                let i = k % lines.len();
                if matches!(m, Mutation::DropLine(_)) {
                    lines.remove(i);
                } else {
                    let l = lines[i].clone();
                    lines.insert(i, l);
                }
                t = lines.join("\n");
            }
            Mutation::Truncate(p) => {
                let mut cut = t.len() * p as usize / 100;
                while !t.is_char_boundary(cut) {
                    cut -= 1;
                }
                t.truncate(cut);
            }
            Mutation::RenameKey(k) => {
                let keys: Vec<usize> = t
                    .match_indices(if toml { " =" } else { "\":" })
                    .map(|(i, _)| i)
                    .collect();
                if let Some(&i) = keys.get(k % keys.len().max(1)) {
                    t.insert(i, 'x');
                }
            }
        }
    }
    t
}

#[test]
fn mutated_cases_never_panic_and_errors_name_a_field() {
    for toml in [false, true] {
        let base = if toml {
            // The same case in TOML.
            let v: serde_json::Value = serde_json::from_str(CASE).unwrap();
            toml::to_string(&v).unwrap()
        } else {
            CASE.to_string()
        };
        run(1500, mutation(), |muts| {
            let text = apply(&base, &muts, toml);
            let outcome = catch_unwind(AssertUnwindSafe(|| {
                parse_case(&text, Some(!toml))
                    .map_err(|e| e.to_string())
                    .and_then(|input| Case::from_input(&input).map_err(|e| e.to_string()))
                    .and_then(|case| case.solve().map_err(|e| e.to_string()))
            }));
            let result =
                outcome.map_err(|_| TestCaseError::fail(format!("panicked on:\n{text}")))?;
            match result {
                Ok(out) => {
                    // Accepted input gives a finite answer.
                    let finite = out
                        .velocity
                        .iter()
                        .chain(&out.angular_velocity)
                        .all(|x| x.is_finite())
                        && out.energy_after.is_finite();
                    prop_assert!(finite, "non-finite output for:\n{text}");
                }
                Err(msg) => {
                    prop_assert!(
                        !msg.is_empty() && !msg.contains('\n') || msg.contains("line"),
                        "unclear error {msg:?}"
                    );
                    let names_something =
                        msg.contains(": ") || msg.contains("line") || msg.contains("column");
                    prop_assert!(names_something, "error names no field or position: {msg:?}");
                }
            }
            Ok(())
        });
    }
}

#[test]
fn mutated_scenes_never_panic_and_errors_name_file_and_field() {
    run(800, mutation(), |muts| {
        let text = apply(SCENE, &muts, true);
        let outcome = catch_unwind(AssertUnwindSafe(|| {
            Scene::parse("scene.toml", &text)
                .and_then(|raw| Scene::validate("scene.toml", &text, raw))
        }));
        let result = outcome.map_err(|_| TestCaseError::fail(format!("panicked on:\n{text}")))?;
        match result {
            Err(e) => {
                let msg = e.to_string();
                prop_assert!(msg.starts_with("scene.toml"), "{msg}");
                prop_assert!(!e.field.is_empty() && !e.message.is_empty(), "{msg}");
            }
            Ok(scene) => {
                // An accepted scene runs to finite statistics.
                let mut raw = scene.raw().clone();
                raw.samples = 512;
                let small = Scene::validate("scene.toml", &text, raw).unwrap();
                let r = run_scene(
                    &small,
                    &RunOptions {
                        threads: 1,
                        progress: false,
                        ..Default::default()
                    },
                )
                .map_err(|e| TestCaseError::fail(e.to_string()))?;
                for law in &r.acc.laws {
                    if law.impacts > 0 {
                        for m in [
                            &law.energy_ratio.moments,
                            &law.omega_after_norm.moments,
                            &law.velocity_after_norm.moments,
                        ] {
                            prop_assert!(
                                m.mean().is_finite() && m.sd().is_finite(),
                                "non-finite statistics for:\n{text}"
                            );
                        }
                    }
                }
            }
        }
        Ok(())
    });
}
