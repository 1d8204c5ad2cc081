//! An RQMC run's intervals: every estimate of the summary keeps its point
//! value over all samples, and takes its 95 % half-width from the spread of
//! the same estimate over the run's replicates (Student t, R − 1 degrees of
//! freedom), with the variance gain over independent sampling.

use std::collections::HashMap;

use crate::output::summary::{Interval, Named, StatSummary, Summary};
use crate::stats::proportion;
use crate::stats::student::replicate_interval;

/// One estimate as the walk meets it: its path, its point value, its
/// independent-sampling half-width, and whether it is a proportion (which
/// a replicate without the entry has at 0: planes hit and sequences list
/// only the counts seen).
struct Estimate<'a> {
    path: &'a str,
    value: f64,
    mc_ci95: f64,
    proportion: bool,
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
            let mut values = by_path.get(e.path).cloned().unwrap_or_default();
            if e.proportion && values.len() < r {
                values.resize(r, 0.0);
            }
            Some(if values.len() == r {
                replicate_interval(&values, e.mc_ci95)
            } else {
                (f64::NAN, f64::NAN)
            })
        });
    }

    /// Every estimate with an interval: the statistics (means and ratios),
    /// the fractions and active sets, the paired differences between laws,
    /// and a drop's per-bounce statistics and planes hit, endings and
    /// sequences.
    fn walk(&mut self, f: &mut Visit) {
        for (law, ls) in self.laws.0.iter_mut() {
            for (group, g) in ls.groups.0.iter_mut() {
                let at = format!("laws/{law}/{group}");
                for (name, st) in g.stats.0.iter_mut() {
                    stat(&format!("{at}/stats/{name}"), st, f);
                }
                shares(
                    &format!("{at}/fractions"),
                    &g.fractions,
                    &mut g.fractions_ci95,
                    Some(&mut g.fractions_gain),
                    f,
                );
                shares(
                    &format!("{at}/active_sets"),
                    &g.active_sets,
                    &mut g.active_sets_ci95,
                    Some(&mut g.active_sets_gain),
                    f,
                );
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
                shares(&format!("{at}/energy_gain_only"), only, cis, None, f);
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
                shares(
                    &format!("{at}/planes_hit"),
                    &b.planes_hit,
                    &mut b.planes_hit_ci95,
                    None,
                    f,
                );
            }
            let e = &d.endings;
            let endings = Named(
                [
                    ("flew_away", e.flew_away),
                    ("came_to_rest", e.came_to_rest),
                    ("bounce_limit", e.bounce_limit),
                    ("unsolved", e.unsolved),
                    ("stalled", e.stalled),
                    ("settled", e.settled),
                ]
                .into_iter()
                .map(|(k, v)| (k.to_string(), v))
                .collect(),
            );
            shares(
                &format!("drops/{law}/endings"),
                &endings,
                &mut d.endings_ci95,
                None,
                f,
            );
            for q in d.sequences.iter_mut() {
                let path = format!("drops/{law}/sequences/{}", q.sequence);
                share(&path, q.fraction, &mut q.ci95, f);
            }
        }
    }
}

/// Proportions by name as estimates: each interval from the replicates
/// ([`share`]), and the gains where asked for.
fn shares(
    at: &str,
    values: &Named<f64>,
    cis: &mut Named<Interval>,
    mut gains: Option<&mut Named<f64>>,
    f: &mut Visit,
) {
    for (name, &p) in values.iter() {
        let mut ci = cis.get(name).copied().unwrap_or(Interval::NAN);
        if let Some(gain) = share(&format!("{at}/{name}"), p, &mut ci, f) {
            cis.set(name, ci);
            if let Some(g) = gains.as_deref_mut() {
                g.set(name, gain);
            }
        }
    }
}

/// A proportion as an estimate, `ci` its interval from the pooled count
/// (Wilson's), whose half-width stands for independent sampling's in the
/// gain. The replicates' interval replaces it, except for a count of none
/// (or of all), where the replicates agree and the pooled bound stays
/// ([`proportion::replicated`]); its gain is then undefined.
fn share(path: &str, p: f64, ci: &mut Interval, f: &mut Visit) -> Option<f64> {
    let pooled = *ci;
    let (half, gain) = f(Estimate {
        path,
        value: p,
        mc_ci95: pooled.half_width(),
        proportion: true,
    })?;
    *ci = Interval(proportion::replicated(p, half, pooled.0));
    let edge = pooled.low() == 0.0 || pooled.high() == 1.0;
    Some(if edge { f64::NAN } else { gain })
}

/// A statistic's mean as an estimate.
fn stat(path: &str, st: &mut StatSummary, f: &mut Visit) {
    if let Some((ci, gain)) = f(Estimate {
        path,
        value: st.mean,
        mc_ci95: st.ci95,
        proportion: false,
    }) {
        st.ci95 = ci;
        st.gain = Some(gain);
    }
}
