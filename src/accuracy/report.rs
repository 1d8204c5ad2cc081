//! The ladder's report: `accuracy.parquet` and `accuracy.md`, and the
//! folder with the plot ([`super::plot`]).

use std::path::Path;

use polars::prelude::*;

use super::*;

impl Ladder {
    /// `accuracy.parquet`: one row per rung (family `law`, `compliant`,
    /// `precision`, `contact_point`) and per sample count (family
    /// `sample_count`); columns that do not apply are null (`*_vs_stronge`
    /// outside scenes with one frictional contact).
    pub fn frame(&self) -> PolarsResult<DataFrame> {
        let mut family = Vec::new();
        let mut rung = Vec::new();
        let mut precision = Vec::new();
        let mut ns = Vec::new();
        let mut cols: Vec<Vec<Option<f64>>> = vec![Vec::new(); 18];
        let mut point: [Vec<Option<f64>>; 2] = [Vec::new(), Vec::new()];
        let mut samples = Vec::new();
        let mut wall = Vec::new();
        let mut ci = Vec::new();
        let mut mean = Vec::new();
        let fin = |x: f64| x.is_finite().then_some(x);
        for r in &self.rungs {
            family.push(r.family.clone());
            rung.push(r.rung.clone());
            precision.push(r.precision.clone());
            ns.push(Some(r.ns_per_sample));
            let e = [
                r.vs_compliant,
                r.vs_newton,
                r.vs_stronge.unwrap_or(Errors::NONE),
            ];
            let vals: Vec<f64> = e
                .iter()
                .flat_map(|e| [e.v_rms, e.v_p99, e.w_rms, e.w_p99, e.ratio_rms, e.ratio_p99])
                .collect();
            for (c, v) in cols.iter_mut().zip(vals) {
                c.push(fin(v));
            }
            point[0].push(r.point_error.map(|p| p.0));
            point[1].push(r.point_error.map(|p| p.1));
            samples.push(Some(self.knobs.samples as u64));
            wall.push(None);
            ci.push(None);
            mean.push(None);
        }
        for c in &self.counts {
            family.push(match c.sampling.as_str() {
                "mc" => "sample_count".into(),
                other => format!("sample_count_{other}"),
            });
            rung.push(format!("n{}", c.samples));
            precision.push(String::new());
            ns.push(Some(
                c.wall_seconds * 1e9 * c.threads as f64 / c.samples as f64,
            ));
            for col in cols.iter_mut() {
                col.push(None);
            }
            point[0].push(None);
            point[1].push(None);
            samples.push(Some(c.samples));
            wall.push(Some(c.wall_seconds));
            ci.push(Some(c.ci95));
            mean.push(Some(c.mean));
        }
        let names = [
            "v_after_rms_vs_compliant",
            "v_after_p99_vs_compliant",
            "omega_after_rms_vs_compliant",
            "omega_after_p99_vs_compliant",
            "energy_ratio_rms_vs_compliant",
            "energy_ratio_p99_vs_compliant",
            "v_after_rms_vs_newton",
            "v_after_p99_vs_newton",
            "omega_after_rms_vs_newton",
            "omega_after_p99_vs_newton",
            "energy_ratio_rms_vs_newton",
            "energy_ratio_p99_vs_newton",
            "v_after_rms_vs_stronge",
            "v_after_p99_vs_stronge",
            "omega_after_rms_vs_stronge",
            "omega_after_p99_vs_stronge",
            "energy_ratio_rms_vs_stronge",
            "energy_ratio_p99_vs_stronge",
        ];
        let height = family.len();
        let mut columns = vec![
            Column::new("family".into(), family),
            Column::new("rung".into(), rung),
            Column::new("precision".into(), precision),
            Column::new("ns_per_sample".into(), ns),
            Column::new("samples".into(), samples),
        ];
        for (name, c) in names.iter().zip(cols) {
            columns.push(Column::new((*name).into(), c));
        }
        let [p0, p1] = point;
        columns.push(Column::new("point_error_rms".into(), p0));
        columns.push(Column::new("point_error_p99".into(), p1));
        let fl = |f: &dyn Fn(&Rung) -> Option<f64>| -> Vec<Option<f64>> {
            self.rungs
                .iter()
                .map(f)
                .chain(self.counts.iter().map(|_| None))
                .collect()
        };
        columns.push(Column::new(
            "v_after_rms_vs_flight_reference".into(),
            fl(&|r| r.vs_flight_reference.map(|e| e.v_rms)),
        ));
        columns.push(Column::new(
            "v_after_p99_vs_flight_reference".into(),
            fl(&|r| r.vs_flight_reference.map(|e| e.v_p99)),
        ));
        columns.push(Column::new(
            "omega_after_rms_vs_flight_reference".into(),
            fl(&|r| r.vs_flight_reference.map(|e| e.w_rms)),
        ));
        columns.push(Column::new(
            "energy_ratio_rms_vs_flight_reference".into(),
            fl(&|r| r.vs_flight_reference.map(|e| e.ratio_rms)),
        ));
        columns.push(Column::new(
            "impact_time_rms_error".into(),
            fl(&|r| r.time_error.map(|t| t.0)),
        ));
        columns.push(Column::new(
            "impact_time_p99_error".into(),
            fl(&|r| r.time_error.map(|t| t.1)),
        ));
        columns.push(Column::new(
            "unseparated_fraction".into(),
            fl(&|r| r.unseparated),
        ));
        columns.push(Column::new("wall_seconds".into(), wall));
        columns.push(Column::new("energy_ratio_mean".into(), mean));
        columns.push(Column::new("energy_ratio_ci95".into(), ci));
        // The sample-count rows: the most frequent active set's share.
        let counts = |f: &dyn Fn(&CountRow) -> Option<f64>| -> Vec<Option<f64>> {
            self.rungs
                .iter()
                .map(|_| None)
                .chain(self.counts.iter().map(f))
                .collect()
        };
        columns.push(Column::new(
            "share_set".into(),
            self.rungs
                .iter()
                .map(|_| None)
                .chain(self.counts.iter().map(|c| Some(c.share_name.clone())))
                .collect::<Vec<Option<String>>>(),
        ));
        columns.push(Column::new("share".into(), counts(&|c| Some(c.share))));
        columns.push(Column::new(
            "share_ci95".into(),
            counts(&|c| Some(c.share_ci95).filter(|x| x.is_finite())),
        ));
        DataFrame::new(height, columns)
    }

    /// The Markdown report.
    pub fn markdown(&self, header: &str) -> String {
        let mut s = String::new();
        s.push_str(&format!(
            "# Accuracy ladder: {}\n\n{header}\n\n",
            self.scene
        ));
        if self.rungs.iter().any(|r| r.vs_flight_reference.is_some()) {
            s.push_str(&format!(
                "Drop scene: the first impact of the same {} samples with each flight setting, against a reference ten times finer than the finest step and tolerance. Errors: RMS and p99 of |Δv⁺| (m/s), RMS of |Δω⁺| (rad/s) and |Δ(T⁺/T⁻)|, and of the impact time (s). Cost: one-thread ns per sample (flight, time of impact and impact).\n\n| rung | ns/sample | v⁺ RMS | v⁺ p99 | ω⁺ RMS | T⁺/T⁻ RMS | impact time RMS | impact time p99 |\n|---|---|---|---|---|---|---|---|\n",
                self.knobs.samples
            ));
            let g = |x: f64| {
                if x.is_finite() {
                    format!("{x:.2e}")
                } else {
                    "–".into()
                }
            };
            for r in &self.rungs {
                if let (Some(e), Some(t)) = (r.vs_flight_reference, r.time_error) {
                    s.push_str(&format!(
                        "| {} | {:.0} | {} | {} | {} | {} | {} | {} |\n",
                        r.rung,
                        r.ns_per_sample,
                        g(e.v_rms),
                        g(e.v_p99),
                        g(e.w_rms),
                        g(e.ratio_rms),
                        g(t.0),
                        g(t.1)
                    ));
                }
            }
            s.push_str(&self.count_table());
            return s;
        }
        let stronge = self.rungs.iter().any(|r| r.vs_stronge.is_some());
        let rough = self.friction;
        s.push_str(&format!(
            "Errors over the same {} samples, against the finest compliant run ({} RK4 steps per contact, E* = {:e} Pa{}) and against the exact Newton LCP in f64{}: RMS and p99 of |Δv⁺| (m/s), |Δω⁺| (rad/s) and |Δ(T⁺/T⁻)|. Cost: end-to-end ns per sample on one thread (rigid laws: a timed run of {} samples, or of as many as take about 5 s for slow laws, with sampling and statistics; compliant: the integration alone).\n\n",
            self.knobs.samples,
            self.knobs.reference_steps,
            self.knobs.effective_modulus,
            if rough {
                format!(
                    ", regularised Coulomb with ε = {:e} (|v| + L|ω|)",
                    self.knobs.friction_regularisation
                )
            } else {
                String::new()
            },
            if stronge {
                " and `stronge` (the rigid reference for one frictional contact)"
            } else {
                ""
            },
            self.knobs.timing_samples
        ));
        s.push_str("| rung | precision | ns/sample | v⁺ RMS vs compliant | v⁺ p99 | ω⁺ RMS | T⁺/T⁻ RMS | v⁺ RMS vs newton | ω⁺ RMS vs newton | T⁺/T⁻ RMS vs newton |");
        if stronge {
            s.push_str(" v⁺ RMS vs stronge | ω⁺ RMS vs stronge | T⁺/T⁻ RMS vs stronge |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
        } else {
            s.push_str("\n|---|---|---|---|---|---|---|---|---|---|\n");
        }
        let g = |x: f64| {
            if x.is_finite() {
                format!("{x:.2e}")
            } else {
                "–".into()
            }
        };
        for r in self.rungs.iter().filter(|r| r.family != "contact_point") {
            let (c, n) = (r.vs_compliant, r.vs_newton);
            s.push_str(&format!(
                "| {} | {} | {:.1} | {} | {} | {} | {} | {} | {} | {} |",
                r.rung,
                r.precision,
                r.ns_per_sample,
                g(c.v_rms),
                g(c.v_p99),
                g(c.w_rms),
                g(c.ratio_rms),
                g(n.v_rms),
                g(n.w_rms),
                g(n.ratio_rms)
            ));
            if stronge {
                let t = r.vs_stronge.unwrap_or(Errors::NONE);
                s.push_str(&format!(
                    " {} | {} | {} |",
                    g(t.v_rms),
                    g(t.w_rms),
                    g(t.ratio_rms)
                ));
            }
            s.push('\n');
        }
        let unseparated: Vec<String> = self
            .rungs
            .iter()
            .filter_map(|r| {
                let f = r.unseparated.filter(|f| *f > 0.0)?;
                Some(format!("{} {:.2} %", r.rung, 100.0 * f))
            })
            .collect();
        if !unseparated.is_empty() || self.reference_unseparated > 0 {
            s.push_str(&format!(
                "\nCompliant runs that had not separated when their step budget (200 contact durations) ran out, whose outcome is where the integration stopped: {}; reference: {} of {} samples.\n",
                if unseparated.is_empty() {
                    "none".to_string()
                } else {
                    unseparated.join(", ")
                },
                self.reference_unseparated,
                self.knobs.samples
            ));
        }
        s.push_str("\n**Contact point** (per touching plane; error of the point relative to the closed form, in units of the body's largest semi-axis):\n\n| route | ns/call | error RMS | error p99 |\n|---|---|---|---|\n");
        for r in self.rungs.iter().filter(|r| r.family == "contact_point") {
            let (a, b) = r.point_error.unwrap_or((f64::NAN, f64::NAN));
            s.push_str(&format!(
                "| {} | {:.1} | {} | {} |\n",
                r.rung,
                r.ns_per_sample,
                g(a),
                g(b)
            ));
        }
        s.push_str(&self.count_table());
        s
    }

    /// The sample-count rungs as a Markdown table.
    fn count_table(&self) -> String {
        let mut s = String::new();
        s.push_str(&format!(
            "\n**Sample count** ({} law, all cores): the 95 % CI half-width of the mean energy ratio, and of the most frequent active set's share (a drop scene: of each sample's first impact), against wall time, with independent samples (MC) and with 16 replicates of scrambled Sobol points (RQMC, which runs whole replicates: at least N samples).\n\n| N | sampling | wall (s) | mean | ci95 | ci95·√N | share | share ci95 |\n|---|---|---|---|---|---|---|---|\n",
            self.law_for_counts
        ));
        for c in &self.counts {
            s.push_str(&format!(
                "| {} | {} | {:.3} | {:.6} | {:.2e} | {:.3} | {} {:.4} | {:.2e} |\n",
                c.samples,
                c.sampling,
                c.wall_seconds,
                c.mean,
                c.ci95,
                c.ci95 * (c.samples as f64).sqrt(),
                c.share_name,
                c.share,
                c.share_ci95
            ));
        }
        s
    }

    /// The rungs on the Pareto front of (cost, v⁺ error vs compliant):
    /// none is both cheaper and at least as accurate.
    pub fn pareto(&self) -> Vec<&Rung> {
        let mut pts: Vec<&Rung> = self
            .rungs
            .iter()
            .filter(|r| {
                r.vs_compliant.v_rms.is_finite()
                    && r.rung != format!("compliant{}", self.knobs.reference_steps)
            })
            .collect();
        pts.sort_by(|a, b| a.ns_per_sample.total_cmp(&b.ns_per_sample));
        let mut front: Vec<&Rung> = Vec::new();
        for r in pts {
            if front
                .last()
                .is_none_or(|f| r.vs_compliant.v_rms < f.vs_compliant.v_rms)
            {
                front.push(r);
            }
        }
        front
    }
}

/// Writes a ladder's folder (`accuracy.parquet`, `accuracy.md`,
/// `accuracy.svg`, staged and renamed together) and returns the markdown.
/// `scene` is the scene file, named in the regeneration command.
pub fn write_folder(
    ladder: &Ladder,
    scene: &Path,
    dir: &Path,
) -> Result<String, crate::output::OutputError> {
    use crate::output::manifest::{utc_string, Machine};
    use crate::output::{schema_metadata, write_parquet, OutputError, Staging};
    let machine = Machine::current();
    let header = format!(
        "Regenerate with `cargo run --release -- accuracy {} --out {} --force`. Machine: {} ({} logical cores, {}). Date: {}. impactmc {} ({}).",
        scene.display(),
        dir.display(),
        machine.cpu,
        machine.logical_cores,
        machine.os,
        &utc_string(std::time::SystemTime::now())[..10],
        env!("CARGO_PKG_VERSION"),
        env!("IMPACTMC_GIT_COMMIT"),
    );
    let md = ladder.markdown(&header);
    let target = |name: &str| dir.join(name).display().to_string();
    let svg = plot_svg(ladder).map_err(|message| OutputError::Plot {
        path: target("accuracy.svg"),
        message,
    })?;
    let mut df = ladder.frame().map_err(|source| OutputError::Parquet {
        path: target("accuracy.parquet"),
        source,
    })?;
    let mut staging = Staging::new(dir);
    write_parquet(&mut staging, "accuracy.parquet", &mut df, schema_metadata())?;
    for (name, text) in [("accuracy.md", &md), ("accuracy.svg", &svg)] {
        staging.write(name, |f| {
            use std::io::Write;
            f.write_all(text.as_bytes())
                .map_err(|source| OutputError::Io {
                    path: target(name),
                    source,
                })
        })?;
    }
    staging.commit()?;
    Ok(md)
}
