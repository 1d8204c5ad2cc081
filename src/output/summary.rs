//! The run summary: what `impactmc run` prints (text or JSON) and what the
//! Parquet summary table holds. Built from the merged accumulators only.

use serde::{Deserialize, Serialize};

use crate::config::Scene;
pub use crate::output::named::{FromNull, Named};
use crate::stats::accumulators::LawAcc;
use crate::stats::drops::{resolved, DropAcc, Ending, SIMULTANEITY_TOLERANCES};
use crate::stats::RunResult;

use super::stat_summary::nan_if_null;
pub use super::stat_summary::{Interval, StatSummary};

impl FromNull for StatSummary {}
impl FromNull for GroupSummary {}
impl FromNull for EndingSummary {}
impl FromNull for LawSummary {}
impl FromNull for PairSummary {}
impl FromNull for DropSummary {}
impl FromNull for PointDifference {}
impl FromNull for Named<PointDifference> {}
impl FromNull for Interval {
    fn from_null() -> Option<Self> {
        Some(Interval::NAN)
    }
}

/// One set of samples (all, or one active set): counts, statistics and,
/// for all samples, the fractions flagged and per active set.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct GroupSummary {
    /// Samples in the group.
    pub samples: u64,
    /// Samples with an approaching contact.
    pub impacts: u64,
    /// The statistics, by name (`energy_ratio`, `omega_after_norm`, ...).
    pub stats: Named<StatSummary>,
    /// The fractions of samples flagged, by flag.
    #[serde(default, skip_serializing_if = "Named::is_empty")]
    pub fractions: Named<f64>,
    /// Their 95 % intervals `[low, high]` ([`Interval`]).
    #[serde(default, skip_serializing_if = "Named::is_empty")]
    pub fractions_ci95: Named<Interval>,
    /// By active set (the planes that took an impulse; `(none)` for
    /// none): the fraction of samples.
    #[serde(default, skip_serializing_if = "Named::is_empty")]
    pub active_sets: Named<f64>,
    /// RQMC only: the fractions' gains (the intervals then come from the
    /// replicates, like every interval of such a run).
    #[serde(default, skip_serializing_if = "Named::is_empty")]
    pub fractions_gain: Named<f64>,
    /// The active sets' 95 % intervals `[low, high]`.
    #[serde(default, skip_serializing_if = "Named::is_empty")]
    pub active_sets_ci95: Named<Interval>,
    /// RQMC only: the active sets' gains.
    #[serde(default, skip_serializing_if = "Named::is_empty")]
    pub active_sets_gain: Named<f64>,
}

impl GroupSummary {
    /// No samples, no statistics.
    fn empty() -> Self {
        Self {
            samples: 0,
            impacts: 0,
            stats: Named::default(),
            fractions: Named::default(),
            fractions_ci95: Named::default(),
            active_sets: Named::default(),
            fractions_gain: Named::default(),
            active_sets_ci95: Named::default(),
            active_sets_gain: Named::default(),
        }
    }

    /// `fractions[name]`, NaN where the group has none.
    pub fn fraction(&self, name: &str) -> f64 {
        self.fractions.get(name).copied().unwrap_or(f64::NAN)
    }

    /// The 95 % half-width of a statistic's mean, or half the width of a
    /// fraction's or active set's interval, by name; None for a name the
    /// group does not have.
    pub fn half_width(&self, name: &str) -> Option<f64> {
        self.stats
            .get(name)
            .map(|s| s.ci95)
            .or_else(|| self.fractions_ci95.get(name).map(Interval::half_width))
            .or_else(|| self.active_sets_ci95.get(name).map(Interval::half_width))
    }
}

/// One estimate's difference between a sweep point and the reference
/// point, over the same samples.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct PointDifference {
    /// This point's estimate minus the reference point's.
    #[serde(deserialize_with = "nan_if_null")]
    pub difference: f64,
    /// Its 95 % half-width, from the paired differences (per replicate
    /// under RQMC, per cluster of samples under MC).
    #[serde(deserialize_with = "nan_if_null")]
    pub ci95: f64,
    /// The half-width if the points were independent, √(ci95ₖ² + ci95₀²):
    /// what pairing saved.
    #[serde(deserialize_with = "nan_if_null")]
    pub unpaired_ci95: f64,
}

/// A sweep point's paired differences against the reference point, per
/// law: every mean statistic, fraction and active set (`active_set_SET`)
/// of the law's `all` group.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct PointPairs {
    /// The grid point compared with (the first, or `sweep.reference`).
    pub reference_point: usize,
    /// Where the paired intervals come from: `replicates` (RQMC, Student
    /// t over the replicates' differences) or `clusters` (MC, Student t
    /// over clusters of consecutive samples, delta method).
    pub method: String,
    /// The intervals' degrees of freedom: replicates or clusters, less one.
    pub degrees_of_freedom: u64,
    /// By law, by estimate.
    pub laws: Named<Named<PointDifference>>,
}

/// How a run with a target precision (`[target]`, `--target-ci`) went.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct TargetSummary {
    /// Every statistic reached its half-width.
    pub reached: bool,
    /// The sample counts of the rounds run; the last is the summary's.
    pub rounds: Vec<u64>,
    /// The most samples a round could take.
    pub max_samples: u64,
    /// Per statistic, in name order.
    pub statistics: Vec<TargetStatistic>,
}

/// One statistic of a target.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct TargetStatistic {
    /// Its name: a statistic or a fraction of the summary.
    pub statistic: String,
    /// The half-width asked for.
    pub ci95: f64,
    /// The largest half-width over the laws (and grid points) at the last
    /// round.
    #[serde(deserialize_with = "nan_if_null")]
    pub achieved: f64,
    /// `achieved <= ci95`.
    pub reached: bool,
}

/// One law: its groups, `all` first, then the active sets present (with
/// `by_active_set`).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct LawSummary {
    /// `all`, then each active set present (with `by_active_set`).
    pub groups: Named<GroupSummary>,
}

/// Paired differences `law − laws[0]` over the samples where both impact.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct PairSummary {
    /// The energy ratio's difference.
    pub energy_ratio: StatSummary,
    /// |ω⁺|'s difference.
    pub omega_after_norm: StatSummary,
    /// |v⁺|'s difference.
    pub velocity_after_norm: StatSummary,
    /// The fraction of samples where one law of the pair raises
    /// energy_gain and the other does not, by the law that does (absent
    /// from summaries written before 0.11.0 for drop scenes).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub energy_gain_only: Option<Named<f64>>,
    /// Their 95 % intervals `[low, high]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub energy_gain_only_ci95: Option<Named<Interval>>,
}

/// How a drop scene's samples ended, as fractions of its samples.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Endings {
    /// No further impact within the horizon.
    #[serde(deserialize_with = "nan_if_null")]
    pub flew_away: f64,
    /// Energy after an impact below `energy_floor` of the first impact's.
    #[serde(deserialize_with = "nan_if_null")]
    pub came_to_rest: f64,
    /// Reached the bounce limit.
    #[serde(deserialize_with = "nan_if_null")]
    pub bounce_limit: f64,
    /// An impact the reference could not solve.
    #[serde(deserialize_with = "nan_if_null")]
    pub unsolved: f64,
    /// Repeated touches without approach (a resting or rolling contact
    /// that free flight cannot follow).
    #[serde(deserialize_with = "nan_if_null")]
    pub stalled: f64,
    /// The bounces on one plane accumulated (a Zeno sequence): ended at
    /// their accumulation time, in contact with it.
    #[serde(default, deserialize_with = "nan_if_null")]
    pub settled: f64,
}

/// The walks that ended one way: their share of the samples, the body
/// axis closest to vertical at the end (fractions of these walks), the
/// kinetic energy left after their last impact (J) and the time since
/// release at the end (s; a settled walk's accumulation time).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct EndingSummary {
    #[serde(deserialize_with = "nan_if_null")]
    pub share: f64,
    pub axis_up: AxisUp,
    pub energy_left: StatSummary,
    pub time: StatSummary,
}

/// Which body axis ended closest to vertical, as fractions of the samples.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct AxisUp {
    /// The first semi-axis.
    #[serde(deserialize_with = "nan_if_null")]
    pub a: f64,
    /// The second.
    #[serde(deserialize_with = "nan_if_null")]
    pub b: f64,
    /// The third.
    #[serde(deserialize_with = "nan_if_null")]
    pub c: f64,
}

/// A sequence of sets of planes hit over a drop's first impacts.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct SequenceSummary {
    /// The sets, first to last (`wall_x > floor+wall_y`).
    pub sequence: String,
    /// Samples with it.
    pub count: u64,
    /// Their fraction of the samples.
    #[serde(deserialize_with = "nan_if_null")]
    pub fraction: f64,
    /// Its 95 % interval `[low, high]`.
    pub ci95: Interval,
}

/// The k-th impact of a drop, over the samples that reached it.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct BounceSummary {
    /// The impact's number, from 1.
    pub bounce: usize,
    /// Samples that reached it.
    pub reached: u64,
    /// Their fraction of the samples.
    #[serde(deserialize_with = "nan_if_null")]
    pub fraction_of_samples: f64,
    /// By set of planes that took an impulse, of the samples reaching it.
    pub planes_hit: Named<f64>,
    /// Their 95 % intervals `[low, high]`.
    pub planes_hit_ci95: Named<Interval>,
    /// Energy after / before.
    pub energy_ratio: StatSummary,
    /// Time since the previous impact (s).
    pub interval_seconds: StatSummary,
    /// |v| before (m/s).
    pub speed_before: StatSummary,
    /// By tolerance (metres, `1e-9`): the fraction whose second-nearest
    /// plane was within it at the impact; NaN (null in JSON) below
    /// [`DropSummary::simultaneity_resolved_from`] (not resolved).
    pub simultaneous_within_tolerance: Named<f64>,
    /// Impacts flagged energy_gain.
    pub energy_gain: u64,
    /// Impacts flagged degenerate.
    pub degenerate: u64,
}

/// One law's bounces in a drop scene ([`drop_summary`]).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct DropSummary {
    /// Samples run under the law.
    pub samples: u64,
    /// By number of impacts: the fraction of samples with that many.
    pub impacts_per_sample: Named<f64>,
    /// How the samples ended.
    #[serde(flatten)]
    pub endings: Endings,
    /// Their 95 % intervals `[low, high]`, by ending.
    pub endings_ci95: Named<Interval>,
    /// Which body axis ended nearest vertical, over every walk (however it
    /// ended: see `by_ending` for the walks at rest).
    pub final_axis_up: AxisUp,
    /// Per ending (`flew_away`, …, `settled`) that some walk had.
    #[serde(default)]
    pub by_ending: Named<EndingSummary>,
    /// Settled walks by plane, as fractions of the samples.
    #[serde(default)]
    pub settled_on: Named<f64>,
    /// The first impacts a sequence covers.
    pub sequence_impacts: usize,
    /// Most frequent first.
    pub sequences: Vec<SequenceSummary>,
    /// Per impact number, from the first.
    pub bounces: Vec<BounceSummary>,
    /// Flights and impacts the lanes left to the f64 reference.
    pub reference_flights: u64,
    /// Impacts the lanes left to the f64 reference.
    pub reference_impacts: u64,
    /// What the lanes' time-of-impact searches cost.
    #[serde(default)]
    pub lane_search: LaneSearch,
    /// The smallest simultaneity tolerance the run resolves (m): the
    /// distance within which its searches locate a contact (the scene's
    /// `toi_tolerance`). Below it the shares are null.
    #[serde(default)]
    pub simultaneity_resolved_from: f64,
}

/// How fast a run went.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Throughput {
    /// Samples per wall-clock second.
    pub samples_per_second: f64,
    /// Wall-clock time (s).
    pub wall_seconds: f64,
    /// Process CPU time (s), where the system reports it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cpu_seconds: Option<f64>,
}

/// How an RQMC run drew its samples (absent for MC).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct SamplingSummary {
    /// `rqmc`.
    pub method: String,
    /// Independent scramblings.
    pub replicates: u64,
    /// Points per replicate.
    pub samples_per_replicate: u64,
}

/// The public JSON of `impactmc run --format json`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Summary {
    /// The scene's name.
    pub scene: String,
    /// Samples run.
    pub samples: u64,
    /// The seed.
    pub seed: u64,
    /// RQMC: the replicates; every interval then comes from their spread.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sampling: Option<SamplingSummary>,
    /// `f32` or `f64`.
    pub precision: String,
    /// Worker threads.
    pub threads: usize,
    /// How fast.
    pub throughput: Throughput,
    /// The recorded planes, in scene order: the names active sets use.
    pub contacts: Vec<String>,
    /// Per law, its groups.
    pub laws: Named<LawSummary>,
    /// `LAW-FIRST`: paired differences against the first law, same samples.
    #[serde(default, skip_serializing_if = "Named::is_empty")]
    pub paired: Named<PairSummary>,
    /// A drop scene's bounces per law ([`drop_summary`]); `laws` then
    /// describes each sample's first impact.
    #[serde(default, skip_serializing_if = "Named::is_empty")]
    pub drops: Named<DropSummary>,
    /// A run with a target precision: its rounds and what they reached.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target: Option<TargetSummary>,
    /// A sweep point of an RQMC run: paired differences against the
    /// reference point, from the replicates.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub paired_points: Option<PointPairs>,
}

/// The name of a sequence of sets of planes hit: `wall_x > floor+wall_y`,
/// `(none)` for no impact.
pub fn sequence_name(masks: &[usize], names: &[String]) -> String {
    if masks.is_empty() {
        return "(none)".into();
    }
    masks
        .iter()
        .map(|&m| active_set_name(m, names))
        .collect::<Vec<_>>()
        .join(" > ")
}

/// One law's drop statistics: per bounce (samples reaching it, fractions
/// of the planes hit, energy ratio, interval, speed before, simultaneity),
/// the number of impacts, how the samples ended, the final axis up and the
/// sequences of planes hit over the first impacts (most frequent first).
///
/// Simultaneity tolerances below `resolved_from` (the scene's
/// `toi_tolerance`: contacts are located only to within it) are reported
/// as not resolved (null).
pub fn drop_summary(a: &DropAcc, names: &[String], resolved_from: f64) -> DropSummary {
    let n = a.samples.max(1) as f64;
    let bounces = a
        .bounces
        .iter()
        .enumerate()
        .map(|(k, b)| {
            let of_reached = |c: u64| c as f64 / b.reached.max(1) as f64;
            let (mut planes_hit, mut planes_hit_ci95) = (Named::default(), Named::default());
            for (mask, &c) in b.sets.iter().enumerate() {
                if c > 0 {
                    planes_hit.insert(active_set_name(mask, names), of_reached(c));
                    planes_hit_ci95
                        .insert(active_set_name(mask, names), Interval::wilson(c, b.reached));
                }
            }
            let mut within = Named::default();
            for (&tol, &c) in SIMULTANEITY_TOLERANCES.iter().zip(&b.within) {
                let share = resolved(tol, resolved_from).then(|| of_reached(c));
                within.insert(format!("{tol:e}"), share.unwrap_or(f64::NAN));
            }
            BounceSummary {
                bounce: k + 1,
                reached: b.reached,
                fraction_of_samples: b.reached as f64 / n,
                planes_hit,
                planes_hit_ci95,
                energy_ratio: StatSummary::from_moments(&b.energy_ratio),
                interval_seconds: StatSummary::from_moments(&b.interval),
                speed_before: StatSummary::from_moments(&b.speed_before),
                simultaneous_within_tolerance: within,
                energy_gain: b.energy_gain,
                degenerate: b.degenerate,
            }
        })
        .collect();
    let ended = |e: Ending| a.endings[e as usize] as f64 / n;
    let endings_ci95 = Named(
        [
            ("flew_away", Ending::FlewAway),
            ("came_to_rest", Ending::CameToRest),
            ("bounce_limit", Ending::BounceLimit),
            ("unsolved", Ending::Unsolved),
            ("stalled", Ending::Stalled),
            ("settled", Ending::Settled),
        ]
        .into_iter()
        .map(|(name, e)| {
            (
                name.to_string(),
                Interval::wilson(a.endings[e as usize], a.samples),
            )
        })
        .collect(),
    );
    let axes = |up: [u64; 3], of: u64| {
        let f = |k: usize| up[k] as f64 / of.max(1) as f64;
        AxisUp {
            a: f(0),
            b: f(1),
            c: f(2),
        }
    };
    let by_ending = Named(
        Ending::ALL
            .iter()
            .zip(&a.by_ending)
            .zip(&a.endings)
            .filter(|(_, &c)| c > 0)
            .map(|((e, by), &c)| {
                let summary = EndingSummary {
                    share: c as f64 / n,
                    axis_up: axes(by.axis_up, c),
                    energy_left: StatSummary::from_moments(&by.energy_left),
                    time: StatSummary::from_moments(&by.time),
                };
                (e.name().to_string(), summary)
            })
            .collect(),
    );
    let settled_on = Named(
        names
            .iter()
            .zip(&a.settled_on)
            .filter(|(_, &c)| c > 0)
            .map(|(p, &c)| (p.clone(), c as f64 / n))
            .collect(),
    );
    DropSummary {
        samples: a.samples,
        impacts_per_sample: Named(
            a.impacts
                .iter()
                .enumerate()
                .map(|(k, &c)| (k.to_string(), c as f64 / n))
                .collect(),
        ),
        endings: Endings {
            flew_away: ended(Ending::FlewAway),
            came_to_rest: ended(Ending::CameToRest),
            bounce_limit: ended(Ending::BounceLimit),
            unsolved: ended(Ending::Unsolved),
            stalled: ended(Ending::Stalled),
            settled: ended(Ending::Settled),
        },
        endings_ci95,
        final_axis_up: axes(a.final_axis_up(), a.samples),
        by_ending,
        settled_on,
        simultaneity_resolved_from: resolved_from,
        sequence_impacts: a.sequence_impacts(),
        sequences: a
            .sequences_by_frequency()
            .into_iter()
            .map(|(cell, c)| SequenceSummary {
                sequence: sequence_name(&a.sequence_masks(cell), names),
                count: c,
                fraction: c as f64 / n,
                ci95: Interval::wilson(c, a.samples),
            })
            .collect(),
        bounces,
        reference_flights: a.reference_flights,
        reference_impacts: a.reference_impacts,
        lane_search: LaneSearch {
            flights: a.lane_flights,
            poses_per_flight: (a.lane_flights > 0)
                .then(|| a.lane_poses as f64 / a.lane_flights as f64),
            poses_per_sample: a.lane_poses as f64 / n,
        },
    }
}

/// The lanes' time-of-impact searches of a drop run: the flights they
/// searched, and the attitudes (poses) they evaluated per flight and per
/// sample, counted in each walk's own lane (a block evaluates every lane
/// at each step, so idle lanes add to its cost).
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct LaneSearch {
    pub flights: u64,
    /// Null when no flight was searched in lanes.
    pub poses_per_flight: Option<f64>,
    pub poses_per_sample: f64,
}

/// `+`-joined names of the planes in an active-set mask, in scene order;
/// `(none)` for the empty set.
pub fn active_set_name(mask: usize, names: &[String]) -> String {
    if mask == 0 {
        return "(none)".into();
    }
    names
        .iter()
        .enumerate()
        .filter(|(i, _)| mask & (1 << i) != 0)
        .map(|(_, n)| n.as_str())
        .collect::<Vec<_>>()
        .join("+")
}

/// The proportion `k/n` and its 95 % interval (Wilson's); NaN for `n = 0`.
pub fn proportion(k: u64, n: u64) -> (f64, Interval) {
    if n == 0 {
        return (f64::NAN, Interval::NAN);
    }
    (k as f64 / n as f64, Interval::wilson(k, n))
}

/// The three headline statistics, by name.
fn headline(
    energy_ratio: StatSummary,
    omega: StatSummary,
    velocity: StatSummary,
) -> Named<StatSummary> {
    Named(vec![
        ("energy_ratio".into(), energy_ratio),
        ("omega_after_norm".into(), omega),
        ("velocity_after_norm".into(), velocity),
    ])
}

/// One law's groups; `pilots` are the restitution statistics' pilot ratios
/// ([`crate::stats::block::pilots`]).
fn law_summary(
    acc: &LawAcc,
    contacts: &[String],
    pilots: &[f64],
    by_active_set: bool,
) -> LawSummary {
    let mut stats = headline(
        StatSummary::from_stat(&acc.energy_ratio),
        StatSummary::from_stat(&acc.omega_after_norm),
        StatSummary::from_stat(&acc.velocity_after_norm),
    );
    for (i, name) in contacts.iter().enumerate() {
        stats.insert(
            format!("impulse_{name}"),
            StatSummary::from_stat(&acc.impulse[i]),
        );
        stats.insert(
            format!("rebound_{name}"),
            StatSummary::from_stat(&acc.rebound[i]),
        );
        stats.insert(
            format!("restitution_{name}"),
            StatSummary::from_ratio(&acc.restitution[i], pilots[i], &acc.rebound[i].moments),
        );
        if let Some(fr) = &acc.friction {
            stats.insert(
                format!("tangential_impulse_{name}"),
                StatSummary::from_stat(&fr.tangential_impulse[i]),
            );
            stats.insert(
                format!("sliding_speed_{name}"),
                StatSummary::from_stat(&fr.sliding_speed[i]),
            );
        }
    }
    let mut fractions = Named::default();
    let mut cis = Named::default();
    let mut add = |name: String, k: u64, n: u64| {
        let (p, ci) = proportion(k, n);
        fractions.insert(name.clone(), p);
        cis.insert(name, ci);
    };
    for (name, k) in [
        ("impacting", acc.impacts),
        ("energy_gain", acc.energy_gain),
        ("degenerate", acc.degenerate),
        ("jammed", acc.jammed),
        ("unsolved", acc.unsolved),
        ("recomputed_f64", acc.recomputed),
        ("penetrating", acc.penetrating),
    ] {
        add(name.into(), k, acc.samples);
    }
    if let Some(fr) = &acc.friction {
        for (name, k) in [
            ("ambiguous", fr.ambiguous),
            ("unconverged", fr.unconverged),
            ("coupled_fallback", fr.coupled_fallback),
        ] {
            add(name.into(), k, acc.samples);
        }
        // Of the plane's active contacts, those that end sticking.
        for (i, name) in contacts.iter().enumerate() {
            add(format!("sticking_{name}"), fr.sticking[i], fr.active[i]);
        }
    }
    let (mut active_sets, mut active_sets_ci95) = (Named::default(), Named::default());
    for (mask, &k) in acc.active_sets.iter().enumerate() {
        let (p, ci) = proportion(k, acc.samples);
        active_sets.insert(active_set_name(mask, contacts), p);
        active_sets_ci95.insert(active_set_name(mask, contacts), ci);
    }
    let mut groups = Named::default();
    groups.insert(
        "all",
        GroupSummary {
            samples: acc.samples,
            impacts: acc.impacts,
            stats,
            fractions,
            fractions_ci95: cis,
            active_sets,
            active_sets_ci95,
            ..GroupSummary::empty()
        },
    );
    for (mask, g) in acc.groups.iter().enumerate() {
        if g.samples == 0 || !by_active_set {
            continue;
        }
        groups.insert(
            active_set_name(mask, contacts),
            GroupSummary {
                samples: g.samples,
                impacts: g.impacts,
                stats: headline(
                    StatSummary::from_stat(&g.energy_ratio),
                    StatSummary::from_stat(&g.omega_after_norm),
                    StatSummary::from_stat(&g.velocity_after_norm),
                ),
                fractions: Named::default(),
                fractions_ci95: Named::default(),
                active_sets: Named::default(),
                ..GroupSummary::empty()
            },
        );
    }
    LawSummary { groups }
}

impl Summary {
    /// The summary of a run; with RQMC replicates, every interval from
    /// their spread (`replicated`).
    pub fn new(scene: &Scene, result: &RunResult) -> Self {
        let mut summary = Self::of_acc(scene, &result.acc, result);
        if let Some(replicates) = scene.sampling().replicates() {
            let reps: Vec<Summary> = result
                .replicates
                .iter()
                .map(|acc| Self::of_acc(scene, acc, result))
                .collect();
            summary.sampling = Some(SamplingSummary {
                method: scene.sampling().name().into(),
                replicates,
                samples_per_replicate: scene.sampling().samples_per_replicate().unwrap_or(0),
            });
            summary.replicated(&reps, replicates as usize);
        }
        summary
    }

    /// The summary of one accumulator (the run's, or a replicate's), with
    /// the run's timing.
    fn of_acc(scene: &Scene, acc: &crate::stats::accumulators::RunAcc, result: &RunResult) -> Self {
        let contacts: Vec<String> = scene
            .recorded_planes()
            .iter()
            .map(|&i| scene.planes()[i].name.clone())
            .collect();
        let by_set = scene.effects().statistics.by_active_set;
        let pilots = crate::stats::block::pilots(scene);
        let laws = Named(
            scene
                .laws()
                .iter()
                .zip(&acc.laws)
                .map(|(law, acc)| (law.name(), law_summary(acc, &contacts, &pilots, by_set)))
                .collect(),
        );
        // The samples the accumulators hold: the scene's count, except for
        // a shard's share or a partial merge.
        let samples = acc.laws.first().map_or(0, |l| l.samples);
        let mut paired = Named::default();
        let first = scene.laws()[0].name();
        for (law, p) in scene.laws().iter().skip(1).zip(&acc.pairs) {
            // The fraction of samples where one law of the pair raises
            // energy_gain (at a drop's first impact) and the other does not.
            let (mut only, mut cis) = (Named::default(), Named::default());
            for (name, k) in [
                (law.name(), p.energy_gain_only),
                (first.clone(), p.first_energy_gain_only),
            ] {
                let (f, ci) = proportion(k, samples);
                only.insert(name.clone(), f);
                cis.insert(name, ci);
            }
            paired.insert(
                format!("{}-{first}", law.name()),
                PairSummary {
                    energy_ratio: StatSummary::from_moments(&p.energy_ratio),
                    omega_after_norm: StatSummary::from_moments(&p.omega_after_norm),
                    velocity_after_norm: StatSummary::from_moments(&p.velocity_after_norm),
                    energy_gain_only: Some(only),
                    energy_gain_only_ci95: Some(cis),
                },
            );
        }
        let drops = Named(
            scene
                .laws()
                .iter()
                .zip(&acc.drops)
                .map(|(law, acc)| {
                    let resolved_from = scene.effects().toi_tolerance;
                    (law.name(), drop_summary(acc, &contacts, resolved_from))
                })
                .collect(),
        );
        // The precision the lanes computed in (a drop's per-impact rows
        // are f64 whatever it is: its walks carry f64 states between
        // flights).
        let precision = scene.precision().name();
        Summary {
            scene: scene.name().to_string(),
            samples,
            seed: scene.seed(),
            sampling: None,
            precision: precision.to_string(),
            threads: result.threads,
            throughput: Throughput {
                samples_per_second: samples as f64 / result.wall_seconds,
                wall_seconds: result.wall_seconds,
                cpu_seconds: result.cpu_seconds,
            },
            contacts,
            laws,
            paired,
            drops,
            target: None,
            paired_points: None,
        }
    }

    /// The summaries of an RQMC run's replicates (none for MC), each as
    /// [`Summary::new`] makes the run's from all samples.
    pub fn replicate_summaries(scene: &Scene, result: &RunResult) -> Vec<Summary> {
        result
            .replicates
            .iter()
            .map(|acc| Self::of_acc(scene, acc, result))
            .collect()
    }

    /// `summary.laws[law].groups.all`.
    pub fn all_group(&self, law: &str) -> Option<&GroupSummary> {
        self.laws.get(law)?.groups.get("all")
    }
}
