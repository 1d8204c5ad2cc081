//! Paired differences between sweep points. Every point runs the same
//! samples (common random numbers), so a point's estimate minus the
//! reference point's has the noise of paired differences: under RQMC the
//! spread of the replicates' differences, under MC that of clusters of
//! consecutive samples ([`crate::stats::clusters`]).

use std::collections::HashMap;

use crate::output::summary::{
    active_set_name, Interval, Named, PointDifference, PointPairs, Summary,
};
use crate::stats::clusters::{ClusterSums, Key};
use crate::stats::student::replicate_interval;

/// What the paired intervals come from.
pub enum Spread<'a> {
    /// RQMC: this point's and the reference point's replicate summaries
    /// ([`Summary::replicate_summaries`]), in replicate order.
    Replicates {
        mine: &'a [Summary],
        reference: &'a [Summary],
    },
    /// MC: the two runs' cluster sums.
    Clusters {
        mine: &'a ClusterSums,
        reference: &'a ClusterSums,
    },
}

impl Spread<'_> {
    fn method(&self) -> (&'static str, u64) {
        match self {
            Spread::Replicates { mine, .. } => ("replicates", mine.len().saturating_sub(1) as u64),
            Spread::Clusters { mine, .. } => ("clusters", mine.clusters().saturating_sub(1) as u64),
        }
    }
}

/// A law's estimates in a summary's `all` group, by name: each mean
/// statistic, fraction and active set (`active_set_SET`) with its point
/// value and 95 % half-width (for a proportion, half its interval's width).
fn law_estimates(s: &Summary, law: &str) -> Vec<(String, f64, f64)> {
    let Some(g) = s.all_group(law) else {
        return Vec::new();
    };
    let mut out: Vec<(String, f64, f64)> = g
        .stats
        .iter()
        .map(|(k, st)| (k.clone(), st.mean, st.ci95))
        .collect();
    for (k, &p) in g.fractions.iter() {
        let h = g
            .fractions_ci95
            .get(k)
            .map_or(f64::NAN, Interval::half_width);
        out.push((k.clone(), p, h));
    }
    for (k, &p) in g.active_sets.iter() {
        let h = g
            .active_sets_ci95
            .get(k)
            .map_or(f64::NAN, Interval::half_width);
        out.push((format!("active_set_{k}"), p, h));
    }
    out
}

/// The summary's name of a cluster key (as [`law_estimates`] names it).
pub(crate) fn key_name(key: Key, contacts: &[String]) -> String {
    match key {
        Key::Stat(n) | Key::Fraction(n) => n.to_string(),
        Key::PlaneStat(n, i) | Key::PlaneFraction(n, i) => format!("{n}_{}", contacts[i]),
        Key::ActiveSet(mask) => format!("active_set_{}", active_set_name(mask, contacts)),
    }
}

/// The paired 95 % half-width of estimate `name` of law `law` (index
/// `l`) by replicates: Student t over the replicates' differences.
fn by_replicates(
    mine: &[Summary],
    reference: &[Summary],
    law: &str,
    name: &str,
    proportion: bool,
) -> f64 {
    let value = |s: &Summary| -> Option<f64> {
        let found = law_estimates(s, law)
            .into_iter()
            .find(|(k, _, _)| k == name)
            .map(|e| e.1);
        // A replicate without a proportion has it at 0.
        found.or(proportion.then_some(0.0))
    };
    let d: Option<Vec<f64>> = mine
        .iter()
        .zip(reference)
        .map(|(a, b)| Some(value(a)? - value(b)?))
        .collect();
    match d {
        Some(d) if d.len() == mine.len() && d.len() >= 2 => replicate_interval(&d, f64::NAN).0,
        _ => f64::NAN,
    }
}

impl Summary {
    /// This sweep point's paired differences against `reference` (grid
    /// point `reference_point`): each estimate of every law's `all` group
    /// present at both points, its difference, the 95 % half-width of the
    /// paired differences (`spread`), and the unpaired half-width beside
    /// it.
    pub fn paired_with(
        &self,
        reference: &Summary,
        reference_point: usize,
        spread: &Spread,
    ) -> PointPairs {
        let keys: HashMap<String, Key> = match spread {
            Spread::Clusters { mine, .. } => mine
                .keys
                .iter()
                .map(|&k| (key_name(k, &self.contacts), k))
                .collect(),
            Spread::Replicates { .. } => HashMap::new(),
        };
        let mut laws = Named::default();
        for (l, law) in self.laws.keys().enumerate() {
            let base: HashMap<String, (f64, f64)> = law_estimates(reference, law)
                .into_iter()
                .map(|(k, v, h)| (k, (v, h)))
                .collect();
            let mut diffs = Named::default();
            for (name, value, half) in law_estimates(self, law) {
                let Some(&(v0, h0)) = base.get(&name) else {
                    continue;
                };
                let ci95 = match spread {
                    Spread::Replicates {
                        mine,
                        reference: theirs,
                    } => {
                        let proportion = !self
                            .all_group(law)
                            .is_some_and(|g| g.stats.contains_key(&name));
                        by_replicates(mine, theirs, law, &name, proportion)
                    }
                    Spread::Clusters {
                        mine,
                        reference: theirs,
                    } => keys
                        .get(&name)
                        .map_or(f64::NAN, |&k| mine.paired_ci95(theirs, l, k)),
                };
                diffs.insert(
                    name,
                    PointDifference {
                        difference: value - v0,
                        ci95,
                        unpaired_ci95: (half * half + h0 * h0).sqrt(),
                    },
                );
            }
            laws.insert(law.clone(), diffs);
        }
        let (method, dof) = spread.method();
        PointPairs {
            reference_point,
            method: method.into(),
            degrees_of_freedom: dof,
            laws,
        }
    }
}
