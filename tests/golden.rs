//! Every entry of `shared/golden/cases.json`, compared by the rules of
//! `shared/golden/README.md`. The expected values were computed outside
//! impactmc in 40-digit arithmetic.

mod support;

use impactmc::config::case::{Case, CaseInput, CaseOutput};
use serde::Deserialize;

#[derive(Deserialize)]
struct Tolerance {
    velocity_abs: Option<f64>,
    angular_velocity_abs: Option<f64>,
    impulse_rel: Option<f64>,
    impulse_scale: f64,
    energy_rel: Option<f64>,
    length_abs: f64,
}

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

/// Records every comparison; keeps failures and the worst error/tolerance.
#[derive(Default)]
struct Report {
    failures: Vec<String>,
    worst: (f64, String),
    compared: usize,
}

impl Report {
    fn check(&mut self, id: &str, what: &str, got: f64, want: f64, tol: Option<f64>) {
        let Some(tol) = tol else { return };
        self.compared += 1;
        let err = (got - want).abs();
        let ratio = if tol > 0.0 {
            err / tol
        } else if err == 0.0 {
            0.0
        } else {
            f64::INFINITY
        };
        let ratio = if got.is_finite() {
            ratio
        } else {
            f64::INFINITY
        };
        if ratio > self.worst.0 {
            self.worst = (ratio, format!("{id} {what}"));
        }
        if !(ratio <= 1.0) {
            self.failures.push(format!(
                "{id}: {what}: got {got}, expected {want}, error {err:e} > tolerance {tol:e}"
            ));
        }
    }

    fn require(&mut self, id: &str, ok: bool, what: String) {
        self.compared += 1;
        if !ok {
            self.failures.push(format!("{id}: {what}"));
        }
    }
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
        let (x, t) = (&e.expected, &e.tolerance);
        for i in 0..3 {
            r.check(
                id,
                &format!("velocity[{i}]"),
                got.velocity[i],
                x.velocity[i],
                t.velocity_abs,
            );
            r.check(
                id,
                &format!("angular_velocity[{i}]"),
                got.angular_velocity[i],
                x.angular_velocity[i],
                t.angular_velocity_abs,
            );
        }
        let t_scale = x.energy_before.max(x.energy_after);
        let e_tol = t.energy_rel.map(|r| r * t_scale);
        r.check(
            id,
            "energy_before",
            got.energy_before,
            x.energy_before,
            e_tol,
        );
        r.check(id, "energy_after", got.energy_after, x.energy_after, e_tol);
        r.require(
            id,
            got.contacts.len() == x.contacts.len(),
            format!(
                "{} contacts, expected {}",
                got.contacts.len(),
                x.contacts.len()
            ),
        );
        for xc in &x.contacts {
            let Some(gc) = got.contacts.iter().find(|c| c.plane == xc.plane) else {
                r.failures
                    .push(format!("{id}: contact {} missing", xc.plane));
                continue;
            };
            let p = xc.plane;
            r.require(
                id,
                gc.touching == xc.touching,
                format!("contact {p} touching = {}", gc.touching),
            );
            r.require(
                id,
                gc.approaching == xc.approaching,
                format!("contact {p} approaching = {}", gc.approaching),
            );
            for i in 0..3 {
                r.check(
                    id,
                    &format!("contact {p} point[{i}]"),
                    gc.point[i],
                    xc.point[i],
                    Some(t.length_abs),
                );
            }
            r.check(
                id,
                &format!("contact {p} distance"),
                gc.distance,
                xc.distance,
                Some(t.length_abs),
            );
            r.check(
                id,
                &format!("contact {p} normal_velocity_before"),
                gc.normal_velocity_before,
                xc.normal_velocity_before,
                t.velocity_abs,
            );
            r.check(
                id,
                &format!("contact {p} normal_velocity_after"),
                gc.normal_velocity_after,
                xc.normal_velocity_after,
                t.velocity_abs,
            );
            r.check(
                id,
                &format!("contact {p} impulse"),
                gc.impulse,
                xc.impulse,
                t.impulse_rel.map(|r| r * t.impulse_scale),
            );
        }
        for flag in &x.flags {
            r.require(
                id,
                got.flags.contains(flag),
                format!("flag {flag} missing (got {:?})", got.flags),
            );
        }
    }
    eprintln!(
        "golden: {} comparisons over {} entries; worst error/tolerance {:.3} at {}",
        r.compared,
        file.cases.len(),
        r.worst.0,
        r.worst.1
    );
    assert!(
        r.failures.is_empty(),
        "{} golden failures, first 40:\n{}",
        r.failures.len(),
        r.failures
            .iter()
            .take(40)
            .cloned()
            .collect::<Vec<_>>()
            .join("\n")
    );
}
