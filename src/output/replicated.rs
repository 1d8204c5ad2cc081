//! An RQMC run's intervals: every estimate of the summary keeps its point
//! value over all samples, and takes its 95 % half-width from the spread of
//! the same estimate over the run's replicates (Student t, R − 1 degrees of
//! freedom), with the variance gain over independent sampling.

use std::collections::HashMap;

use crate::output::summary::{StatSummary, Summary};
use crate::stats::student::replicate_interval;

/// One estimate as the walk meets it: its path, its point value and its
/// independent-sampling (normal) half-width.
struct Estimate<'a> {
    path: &'a str,
    value: f64,
    mc_ci95: f64,
}

/// What the walk does at each estimate: `Some((ci95, gain))` replaces its
/// interval and sets its gain.
type Visit<'a> = dyn FnMut(Estimate) -> Option<(f64, f64)> + 'a;

impl Summary {
    /// Replaces every interval by the one the `r` replicates' summaries
    /// give (NaN where a replicate lacks the estimate, as a group no
    /// sample of a replicate fell in), and records the gains.
    pub(crate) fn replicated(&mut self, replicates: &[Summary], r: usize) {
        let mut by_path: HashMap<String, Vec<f64>> = HashMap::new();
        for rep in replicates {
            let mut rep = rep.clone();
            rep.walk(&mut |e| {
                by_path.entry(e.path.to_string()).or_default().push(e.value);
                None
            });
        }
        self.walk(&mut |e| {
            let values = by_path.get(e.path).filter(|v| v.len() == r);
            Some(values.map_or((f64::NAN, f64::NAN), |v| replicate_interval(v, e.mc_ci95)))
        });
    }

    /// Every estimate with an interval: the statistics (means and ratios),
    /// the fractions and active sets, the paired differences between laws
    /// and a drop's per-bounce statistics.
    fn walk(&mut self, f: &mut Visit) {
        for (law, ls) in self.laws.0.iter_mut() {
            for (group, g) in ls.groups.0.iter_mut() {
                let at = format!("laws/{law}/{group}");
                for (name, st) in g.stats.0.iter_mut() {
                    stat(&format!("{at}/stats/{name}"), st, f);
                }
                let names: Vec<String> = g.fractions.keys().cloned().collect();
                for name in names {
                    let value = g.fractions[name.as_str()];
                    let mc_ci95 = g.fractions_ci95.get(&name).copied().unwrap_or(f64::NAN);
                    let path = format!("{at}/fractions/{name}");
                    if let Some((ci, gain)) = f(Estimate {
                        path: &path,
                        value,
                        mc_ci95,
                    }) {
                        g.fractions_ci95.set(&name, ci);
                        g.fractions_gain.set(&name, gain);
                    }
                }
                let n = g.samples as f64;
                let names: Vec<String> = g.active_sets.keys().cloned().collect();
                for name in names {
                    let p = g.active_sets[name.as_str()];
                    let path = format!("{at}/active_sets/{name}");
                    if let Some((ci, gain)) = f(Estimate {
                        path: &path,
                        value: p,
                        mc_ci95: 1.959_963_984_540_054 * (p * (1.0 - p) / n).sqrt(),
                    }) {
                        g.active_sets_ci95.set(&name, ci);
                        g.active_sets_gain.set(&name, gain);
                    }
                }
            }
        }
        for (pair, p) in self.paired.0.iter_mut() {
            let at = format!("paired/{pair}");
            stat(&format!("{at}/energy_ratio"), &mut p.energy_ratio, f);
            stat(
                &format!("{at}/omega_after_norm"),
                &mut p.omega_after_norm,
                f,
            );
            stat(
                &format!("{at}/velocity_after_norm"),
                &mut p.velocity_after_norm,
                f,
            );
            if let (Some(only), Some(cis)) = (&p.energy_gain_only, &mut p.energy_gain_only_ci95) {
                for (law, &value) in only.iter() {
                    let mc_ci95 = cis.get(law).copied().unwrap_or(f64::NAN);
                    let path = format!("{at}/energy_gain_only/{law}");
                    if let Some((ci, _)) = f(Estimate {
                        path: &path,
                        value,
                        mc_ci95,
                    }) {
                        cis.set(law, ci);
                    }
                }
            }
        }
        for (law, d) in self.drops.0.iter_mut() {
            for b in d.bounces.iter_mut() {
                let at = format!("drops/{law}/{}", b.bounce);
                stat(&format!("{at}/energy_ratio"), &mut b.energy_ratio, f);
                stat(
                    &format!("{at}/interval_seconds"),
                    &mut b.interval_seconds,
                    f,
                );
                stat(&format!("{at}/speed_before"), &mut b.speed_before, f);
            }
        }
    }
}

/// A statistic's mean as an estimate.
fn stat(path: &str, st: &mut StatSummary, f: &mut Visit) {
    if let Some((ci, gain)) = f(Estimate {
        path,
        value: st.mean,
        mc_ci95: st.ci95,
    }) {
        st.ci95 = ci;
        st.gain = Some(gain);
    }
}
