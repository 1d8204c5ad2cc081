//! The comparison rules of `tests/data/golden/README.md`, shared by the
//! frictionless and the frictional golden files.

use impactmc::config::case::CaseOutput;
use serde::Deserialize;

#[derive(Deserialize)]
pub struct Tolerance {
    pub velocity_abs: Option<f64>,
    pub angular_velocity_abs: Option<f64>,
    pub impulse_rel: Option<f64>,
    pub impulse_scale: f64,
    pub energy_rel: Option<f64>,
    pub length_abs: f64,
    /// Friction entries: `max_k |f_k − e_k| ≤ this × impulse_scale`.
    #[serde(default)]
    pub tangential_impulse_rel: Option<f64>,
}

/// Records every comparison; keeps failures and the worst error/tolerance.
#[derive(Default)]
pub struct Report {
    pub failures: Vec<String>,
    pub worst: (f64, String),
    pub compared: usize,
}

impl Report {
    pub fn check(&mut self, id: &str, what: &str, got: f64, want: f64, tol: Option<f64>) {
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

    pub fn require(&mut self, id: &str, ok: bool, what: String) {
        self.compared += 1;
        if !ok {
            self.failures.push(format!("{id}: {what}"));
        }
    }
}

/// Every quantity of one entry but its flags: velocities, energies and,
/// per contact, touching, approaching, point, distance, normal velocities,
/// impulse and (where the tolerance or the expectation has them) the
/// tangential impulse and `sticking`.
pub fn compare(r: &mut Report, id: &str, got: &CaseOutput, x: &CaseOutput, t: &Tolerance) {
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
        if let Some(rel) = t.tangential_impulse_rel {
            let scale = t.impulse_scale;
            for i in 0..3 {
                r.check(
                    id,
                    &format!("contact {p} tangential_impulse[{i}]"),
                    gc.tangential_impulse[i],
                    xc.tangential_impulse[i],
                    Some(rel * scale),
                );
            }
        }
        if let Some(stick) = xc.sticking {
            r.require(
                id,
                gc.sticking == Some(stick),
                format!("contact {p} sticking = {:?}, expected {stick}", gc.sticking),
            );
        }
    }
}

/// Prints the worst error/tolerance and fails with the first 40 failures.
pub fn finish(r: &Report, what: &str, entries: usize) {
    eprintln!(
        "{what}: {} comparisons over {entries} entries; worst error/tolerance {:.3} at {}",
        r.compared, r.worst.0, r.worst.1
    );
    assert!(
        r.failures.is_empty(),
        "{} {what} failures, first 40:\n{}",
        r.failures.len(),
        r.failures
            .iter()
            .take(40)
            .cloned()
            .collect::<Vec<_>>()
            .join("\n")
    );
}
