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
            let _ = writeln!(
                s,
                "\n[{law}] impacts {} of {} ({:.4}); energy_gain {:.2e}, degenerate {:.2e}, jammed {:.2e}, recomputed_f64 {:.2e}, penetrating {:.2e}",
                all.impacts, all.samples, frac("impacting"), frac("energy_gain"), frac("degenerate"), frac("jammed"),
                frac("recomputed_f64"), frac("penetrating")
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
                .map(|(k, v)| {
                    let name = if k.is_empty() { "(none)" } else { k };
                    match all.active_sets_ci95.get(k) {
                        Some(ci) => format!("{name}={v:.4}±{ci:.1e}"),
                        None => format!("{name}={v:.4}"),
                    }
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
                    .map(|(law, f)| format!("{law} only {f:.2e}"))
                    .collect();
                let _ = write!(s, "; energy_gain in {}", parts.join(", "));
            }
            let _ = writeln!(s);
        }
        s
    }
}

/// The bounce table of one law's [`drop_summary`].
fn drop_text(s: &mut String, d: &DropSummary) {
    use std::fmt::Write;
    let (e, up) = (&d.endings, &d.final_axis_up);
    let _ = writeln!(
        s,
        "  ended: flew away {:.4}, came to rest {:.4}, bounce limit {:.4}, unsolved {:.2e}, stalled {:.2e}; axis closest to vertical at the end: a {:.4}, b {:.4}, c {:.4}",
        e.flew_away, e.came_to_rest, e.bounce_limit, e.unsolved, e.stalled,
        up.a, up.b, up.c
    );
    let _ = writeln!(
        s,
        "  by the f64 reference where lanes left them: {} flights, {} impacts",
        d.reference_flights, d.reference_impacts
    );
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
            .map(|(k, v)| format!("{k} ({v:.3})"))
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
    let top: Vec<String> = d
        .sequences
        .iter()
        .take(5)
        .map(|q| format!("{} {:.4}", q.sequence, q.fraction))
        .collect();
    let _ = writeln!(
        s,
        "  sequences over the first {} impacts (of {}): {}",
        d.sequence_impacts,
        d.sequences.len(),
        top.join(";  ")
    );
}
