//! The summary as text: the table `impactmc run` prints.

use super::summary::*;

impl Summary {
    /// The human-readable table printed by `impactmc run`.
    pub fn to_text(&self) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "scene {}: {} samples, seed {}, {} kernel, {} threads, {:.3} s wall ({:.3e} samples/s)",
            self.scene,
            self.samples,
            self.seed,
            self.precision,
            self.threads,
            self.throughput.wall_seconds,
            self.throughput.samples_per_second
        );
        if let Some(t) = &self.target {
            s.push_str(&t.to_text(self.samples));
        }
        if let Some(q) = &self.sampling {
            let _ = writeln!(
                s,
                "sampling: {}, {} replicates × {} points; every ±95% from the replicates' spread (Student t, {} dof), gain = its variance with independent samples / with these",
                q.method,
                q.replicates,
                q.samples_per_replicate,
                q.replicates - 1
            );
        }
        if self.drops.is_empty() {
            let _ = writeln!(s, "contacts: {}", self.contacts.join(", "));
        } else {
            let _ = writeln!(
                s,
                "drop onto {}; the tables below are each sample's first impact, then its bounces",
                self.contacts.join(", ")
            );
        }
        for (law, summary) in self.laws.iter() {
            let Some(all) = summary.groups.get("all") else {
                continue;
            };
            let frac = |k: &str| all.fraction(k);
            let flag = |k: &str| match all.fractions_ci95.get(k) {
                Some(ci) => share(frac(k), ci),
                None => format!("{:.2e}", frac(k)),
            };
            let _ = writeln!(
                s,
                "\n[{law}] impacts {} of {} ({}); energy_gain {}, degenerate {}, jammed {}, recomputed_f64 {}, penetrating {}",
                all.impacts, all.samples, flag("impacting"), flag("energy_gain"), flag("degenerate"), flag("jammed"),
                flag("recomputed_f64"), flag("penetrating")
            );
            let rqmc = self.sampling.is_some();
            let gain_head = if rqmc {
                format!(" {:>8}", "gain")
            } else {
                String::new()
            };
            let _ = writeln!(
                s,
                "  {:<26} {:>12} {:>10}{gain_head} {:>10} {:>10} {:>10} {:>10}",
                "statistic", "mean", "±95%", "sd", "p01", "median", "p99"
            );
            // The per-contact rebound is heavy-tailed where contacts graze
            // (its mean and sd are then no guide): printed where its
            // quantiles are kept, else `restitution` stands for it.
            let shown = |name: &str, st: &StatSummary| {
                st.is_defined() && (!name.starts_with("rebound_") || st.median.is_some())
            };
            for (name, st) in all.stats.iter().filter(|(n, st)| shown(n, st)) {
                let q = |x: Option<f64>| {
                    x.map(|x| format!("{x:>10.4}"))
                        .unwrap_or_else(|| format!("{:>10}", "-"))
                };
                // A constant's gain is rounding over rounding: shown in
                // e-notation so it keeps to its column.
                let gain = match st.gain {
                    Some(g) if rqmc && g.is_finite() && g < 1e5 => format!(" {g:>8.1}"),
                    Some(g) if rqmc && g.is_finite() => format!(" {g:>8.1e}"),
                    _ if rqmc => format!(" {:>8}", "-"),
                    _ => String::new(),
                };
                let _ = writeln!(
                    s,
                    "  {:<26} {:>12.6} {:>10.2e}{gain} {:>10.4} {} {} {}",
                    name,
                    st.mean,
                    st.ci95,
                    st.sd,
                    q(st.p01),
                    q(st.median),
                    q(st.p99)
                );
            }
            let sets: Vec<String> = all
                .active_sets
                .iter()
                .map(|(k, v)| match all.active_sets_ci95.get(k) {
                    Some(ci) => format!("{k} {}", share(*v, ci)),
                    None => format!("{k} {v:.4}"),
                })
                .collect();
            let _ = writeln!(s, "  active sets: {}", sets.join("  "));
            if all.fractions.contains_key("ambiguous") {
                let sticking: Vec<String> = self
                    .contacts
                    .iter()
                    .map(|c| format!("{c} {:.4}", frac(&format!("sticking_{c}"))))
                    .collect();
                let _ = writeln!(
                    s,
                    "  friction: active contacts ending stuck: {}; ambiguous {:.2e}, unconverged {:.2e}, coupled_fallback {:.2e}",
                    sticking.join(", "),
                    frac("ambiguous"),
                    frac("unconverged"),
                    frac("coupled_fallback")
                );
            }
            if let Some(d) = self.drops.get(law) {
                drop_text(&mut s, d);
            }
        }
        if let Some(pp) = &self.paired_points {
            for (law, diffs) in pp.laws.iter() {
                let parts: Vec<String> =
                    ["energy_ratio", "omega_after_norm", "velocity_after_norm"]
                        .iter()
                        .filter_map(|k| diffs.get(k).map(|d| (k, d)))
                        .map(|(k, d)| {
                            format!(
                                "{k} {:+.6} ± {:.2e} (unpaired ± {:.2e})",
                                d.difference, d.ci95, d.unpaired_ci95
                            )
                        })
                        .collect();
                let _ = writeln!(
                    s,
                    "\n[{law}] minus point {}, paired by {} ({} dof): {}",
                    pp.reference_point,
                    if pp.method == "clusters" {
                        "clusters of samples"
                    } else {
                        "replicate"
                    },
                    pp.degrees_of_freedom,
                    parts.join(", ")
                );
            }
        }
        for (pair, p) in self.paired.iter() {
            let er = &p.energy_ratio;
            let _ = write!(
                s,
                "\npaired {pair}: energy_ratio difference {:.6} ± {:.2e} (sd {:.4}, n {})",
                er.mean, er.ci95, er.sd, er.n
            );
            if let Some(only) = &p.energy_gain_only {
                let parts: Vec<String> = only
                    .iter()
                    .map(|(law, f)| {
                        match p.energy_gain_only_ci95.as_ref().and_then(|c| c.get(law)) {
                            Some(ci) => format!("{law} only {}", share(*f, ci)),
                            None => format!("{law} only {f:.2e}"),
                        }
                    })
                    .collect();
                let _ = write!(s, "; energy_gain in {}", parts.join(", "));
            }
            let _ = writeln!(s);
        }
        s
    }
}

impl TargetSummary {
    /// One line: what was asked, whether it was reached, at what count.
    pub fn to_text(&self, samples: u64) -> String {
        let stats: Vec<String> = self
            .statistics
            .iter()
            .map(|t| {
                format!(
                    "{} ci95 {:.3e} (≤ {:.1e} asked)",
                    t.statistic, t.achieved, t.ci95
                )
            })
            .collect();
        let rounds: Vec<String> = self.rounds.iter().map(u64::to_string).collect();
        let verdict = if self.reached {
            format!("reached at {samples} samples")
        } else {
            format!(
                "NOT reached within max_samples {} (at {samples} samples)",
                self.max_samples
            )
        };
        format!(
            "target: {}; {verdict}; rounds {}\n",
            stats.join(", "),
            rounds.join(", ")
        )
    }
}

/// A proportion and its 95 % interval, `0.1234 [0.1230, 0.1238]`; a
/// count of none as its upper bound, `0 (≤ 3.8e-6)`.
fn share(p: f64, ci: &Interval) -> String {
    if p == 0.0 {
        format!("0 (≤ {:.1e})", ci.high())
    } else if p >= 1e-3 {
        format!("{p:.4} [{:.4}, {:.4}]", ci.low(), ci.high())
    } else {
        format!("{p:.2e} [{:.1e}, {:.1e}]", ci.low(), ci.high())
    }
}

/// The bounce table of one law's [`drop_summary`].
fn drop_text(s: &mut String, d: &DropSummary) {
    use std::fmt::Write;
    let e = &d.endings;
    let ended = |name: &str, p: f64| match d.endings_ci95.get(name) {
        Some(ci) => share(p, ci),
        None => format!("{p:.4}"),
    };
    let _ = writeln!(
        s,
        "  ended: flew away {}, came to rest {}, settled {}, bounce limit {}, unsolved {}, stalled {}",
        ended("flew_away", e.flew_away),
        ended("came_to_rest", e.came_to_rest),
        ended("settled", e.settled),
        ended("bounce_limit", e.bounce_limit),
        ended("unsolved", e.unsolved),
        ended("stalled", e.stalled),
    );
    if !d.settled_on.0.is_empty() {
        let on: Vec<String> = d
            .settled_on
            .iter()
            .map(|(p, f)| format!("{p} {f:.4}"))
            .collect();
        let _ = writeln!(s, "  settled on: {}", on.join(", "));
    }
    // A pose is a resting one only for the walks that settled or came to
    // rest: each ending's own.
    for (name, by) in d.by_ending.iter() {
        let up = &by.axis_up;
        let _ = writeln!(
            s,
            "  {:<13} axis up a {:.4}, b {:.4}, c {:.4}; energy left {:.4e} J; at {:.4} s",
            format!("{name}:"),
            up.a,
            up.b,
            up.c,
            by.energy_left.mean,
            by.time.mean
        );
    }
    let _ = writeln!(
        s,
        "  by the f64 reference where lanes left them: {} flights, {} impacts",
        d.reference_flights, d.reference_impacts
    );
    if let Some(per_flight) = d.lane_search.poses_per_flight {
        let _ = writeln!(
            s,
            "  lanes' searches: {} flights, {per_flight:.1} poses per flight, {:.1} per sample",
            d.lane_search.flights, d.lane_search.poses_per_sample
        );
    }
    let _ = writeln!(
        s,
        "  {:>6} {:>9} {:>21} {:>13} {:>12}  most frequent planes",
        "bounce", "reached", "T+/T- mean ± ci95", "interval (s)", "speed (m/s)"
    );
    for b in &d.bounces {
        if b.reached == 0 {
            continue;
        }
        let best = b
            .planes_hit
            .iter()
            .max_by(|x, y| x.1.partial_cmp(y.1).expect("fractions"))
            .map(|(k, v)| match b.planes_hit_ci95.get(k) {
                Some(ci) => format!("{k} {}", share(*v, ci)),
                None => format!("{k} ({v:.3})"),
            })
            .unwrap_or_default();
        let _ = writeln!(
            s,
            "  {:>6} {:>9} {:>12.5} ± {:.1e} {:>13.4} {:>12.4}  {best}",
            b.bounce,
            b.reached,
            b.energy_ratio.mean,
            b.energy_ratio.ci95,
            b.interval_seconds.mean,
            b.speed_before.mean,
        );
    }
    // The simultaneity curve is in summary.json and simultaneity.parquet;
    // the text says where it stops being resolved.
    let _ = writeln!(
        s,
        "  simultaneity resolved from {:.0e} m (contacts are located to within it); smaller tolerances are null, not 0",
        d.simultaneity_resolved_from
    );
    let top: Vec<String> = d
        .sequences
        .iter()
        .take(5)
        .map(|q| format!("{} {}", q.sequence, share(q.fraction, &q.ci95)))
        .collect();
    let _ = writeln!(
        s,
        "  sequences over the first {} impacts (of {}): {}",
        d.sequence_impacts,
        d.sequences.len(),
        top.join(";  ")
    );
}
