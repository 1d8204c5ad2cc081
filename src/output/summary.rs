//! The run summary: what `impactmc run` prints (text or JSON) and what the
//! Parquet summary table holds. Built from the merged accumulators only.

use serde::{Deserialize, Serialize};
use serde_json::Map;

use crate::config::Scene;
use crate::stats::accumulators::LawAcc;
use crate::stats::drops::{DropAcc, Ending, SIMULTANEITY_TOLERANCES};
use crate::stats::RunResult;
use crate::stats::{Moments, Stat};

/// Mean, spread and quantiles of one statistic. Quantiles are absent where
/// only moments are kept (statistics not listed in `[statistics]
/// quantiles`, paired differences).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct StatSummary {
    pub n: u64,
    pub mean: f64,
    pub ci95: f64,
    pub sd: f64,
    pub min: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub p01: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub median: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub p99: Option<f64>,
    pub max: f64,
}

impl StatSummary {
    pub fn from_moments(m: &Moments) -> Self {
        let n = m.count();
        let nan_if_empty = |x: f64| if n == 0 { f64::NAN } else { x };
        Self {
            n,
            mean: nan_if_empty(m.mean()),
            ci95: m.ci95(),
            sd: nan_if_empty(m.sd()),
            min: nan_if_empty(m.min()),
            p01: None,
            median: None,
            p99: None,
            max: nan_if_empty(m.max()),
        }
    }

    fn from_stat(s: &Stat) -> Self {
        let mut out = Self::from_moments(&s.moments);
        // A statistic whose quantiles were not requested has no histogram.
        if out.n > 0 && s.hist.total() > 0 {
            out.p01 = Some(s.quantile(0.01));
            out.median = Some(s.quantile(0.5));
            out.p99 = Some(s.quantile(0.99));
        }
        out
    }
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct GroupSummary {
    pub samples: u64,
    pub impacts: u64,
    pub stats: Map<String, serde_json::Value>,
    #[serde(default, skip_serializing_if = "Map::is_empty")]
    pub fractions: Map<String, serde_json::Value>,
    #[serde(default, skip_serializing_if = "Map::is_empty")]
    pub fractions_ci95: Map<String, serde_json::Value>,
    #[serde(default, skip_serializing_if = "Map::is_empty")]
    pub active_sets: Map<String, serde_json::Value>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct LawSummary {
    pub groups: Map<String, serde_json::Value>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Throughput {
    pub samples_per_second: f64,
    pub wall_seconds: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cpu_seconds: Option<f64>,
}

/// The public JSON of `impactmc run --format json`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Summary {
    pub scene: String,
    pub samples: u64,
    pub seed: u64,
    pub precision: String,
    pub threads: usize,
    pub throughput: Throughput,
    /// The touching planes, in scene order: the names active sets use.
    pub contacts: Vec<String>,
    pub laws: Map<String, serde_json::Value>,
    /// `LAW-FIRST`: paired differences against the first law, same samples.
    #[serde(default, skip_serializing_if = "Map::is_empty")]
    pub paired: Map<String, serde_json::Value>,
    /// A drop scene's bounces per law ([`drop_summary`]); `laws` then
    /// describes each sample's first impact.
    #[serde(default, skip_serializing_if = "Map::is_empty")]
    pub drops: Map<String, serde_json::Value>,
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
pub fn drop_summary(a: &DropAcc, names: &[String]) -> serde_json::Value {
    use serde_json::json;
    let n = a.samples.max(1) as f64;
    let bounces: Vec<serde_json::Value> = a
        .bounces
        .iter()
        .enumerate()
        .map(|(k, b)| {
            let mut sets = Map::new();
            for (mask, &c) in b.sets.iter().enumerate() {
                if c > 0 {
                    sets.insert(
                        active_set_name(mask, names),
                        json!(c as f64 / b.reached.max(1) as f64),
                    );
                }
            }
            let mut within = Map::new();
            for (tol, &c) in SIMULTANEITY_TOLERANCES.iter().zip(&b.within) {
                within.insert(
                    format!("{tol:e}"),
                    json!(c as f64 / b.reached.max(1) as f64),
                );
            }
            json!({
                "bounce": k + 1,
                "reached": b.reached,
                "fraction_of_samples": b.reached as f64 / n,
                "planes_hit": sets,
                "energy_ratio": json(&StatSummary::from_moments(&b.energy_ratio)),
                "interval_seconds": json(&StatSummary::from_moments(&b.interval)),
                "speed_before": json(&StatSummary::from_moments(&b.speed_before)),
                "simultaneous_within_tolerance": within,
                "energy_gain": b.energy_gain,
                "degenerate": b.degenerate,
            })
        })
        .collect();
    let mut up = Map::new();
    for (name, &c) in ["a", "b", "c"].iter().zip(&a.final_axis_up) {
        up.insert((*name).into(), json!(c as f64 / n));
    }
    let sequences: Vec<serde_json::Value> = a
        .sequences_by_frequency()
        .into_iter()
        .map(|(cell, c)| {
            json!({
                "sequence": sequence_name(&a.sequence_masks(cell), names),
                "count": c,
                "fraction": c as f64 / n,
            })
        })
        .collect();
    let mut out = Map::new();
    out.insert("samples".into(), json!(a.samples));
    out.insert(
        "impacts_per_sample".into(),
        json!(a
            .impacts
            .iter()
            .enumerate()
            .map(|(k, &c)| (k.to_string(), json!(c as f64 / n)))
            .collect::<Map<_, _>>()),
    );
    for (e, &c) in Ending::ALL.iter().zip(&a.endings) {
        out.insert(e.name().into(), json!(c as f64 / n));
    }
    out.insert("final_axis_up".into(), json!(up));
    out.insert("sequence_impacts".into(), json!(a.sequence_impacts()));
    out.insert("sequences".into(), json!(sequences));
    out.insert("bounces".into(), json!(bounces));
    serde_json::Value::Object(out)
}

/// `+`-joined names of the planes in an active-set mask, in scene order.
pub fn active_set_name(mask: usize, names: &[String]) -> String {
    names
        .iter()
        .enumerate()
        .filter(|(i, _)| mask & (1 << i) != 0)
        .map(|(_, n)| n.as_str())
        .collect::<Vec<_>>()
        .join("+")
}

fn json<T: Serialize>(x: &T) -> serde_json::Value {
    serde_json::to_value(x).expect("summary values serialise")
}

/// Proportion and its 95 % half-width (normal approximation).
fn proportion(k: u64, n: u64) -> (f64, f64) {
    if n == 0 {
        return (f64::NAN, f64::NAN);
    }
    let p = k as f64 / n as f64;
    (p, 1.96 * (p * (1.0 - p) / n as f64).sqrt())
}

/// The three headline statistics as a JSON map.
fn headline(
    energy_ratio: StatSummary,
    omega: StatSummary,
    velocity: StatSummary,
) -> Map<String, serde_json::Value> {
    let mut m = Map::new();
    m.insert("energy_ratio".into(), json(&energy_ratio));
    m.insert("omega_after_norm".into(), json(&omega));
    m.insert("velocity_after_norm".into(), json(&velocity));
    m
}

fn law_summary(acc: &LawAcc, contacts: &[String], by_active_set: bool) -> LawSummary {
    let mut stats = headline(
        StatSummary::from_stat(&acc.energy_ratio),
        StatSummary::from_stat(&acc.omega_after_norm),
        StatSummary::from_stat(&acc.velocity_after_norm),
    );
    for (i, name) in contacts.iter().enumerate() {
        stats.insert(
            format!("impulse_{name}"),
            json(&StatSummary::from_stat(&acc.impulse[i])),
        );
        stats.insert(
            format!("rebound_{name}"),
            json(&StatSummary::from_stat(&acc.rebound[i])),
        );
        if let Some(fr) = &acc.friction {
            stats.insert(
                format!("tangential_impulse_{name}"),
                json(&StatSummary::from_stat(&fr.tangential_impulse[i])),
            );
            stats.insert(
                format!("sliding_speed_{name}"),
                json(&StatSummary::from_stat(&fr.sliding_speed[i])),
            );
        }
    }
    let mut fractions = Map::new();
    let mut cis = Map::new();
    for (name, k) in [
        ("impacting", acc.impacts),
        ("energy_gain", acc.energy_gain),
        ("degenerate", acc.degenerate),
        ("jammed", acc.jammed),
        ("unsolved", acc.unsolved),
        ("recomputed_f64", acc.recomputed),
        ("penetrating", acc.penetrating),
    ] {
        let (p, ci) = proportion(k, acc.samples);
        fractions.insert(name.into(), json(&p));
        cis.insert(name.into(), json(&ci));
    }
    if let Some(fr) = &acc.friction {
        for (name, k) in [
            ("ambiguous", fr.ambiguous),
            ("unconverged", fr.unconverged),
            ("coupled_fallback", fr.coupled_fallback),
        ] {
            let (p, ci) = proportion(k, acc.samples);
            fractions.insert(name.into(), json(&p));
            cis.insert(name.into(), json(&ci));
        }
        // Of the plane's active contacts, those that end sticking.
        for (i, name) in contacts.iter().enumerate() {
            let (p, ci) = proportion(fr.sticking[i], fr.active[i]);
            fractions.insert(format!("sticking_{name}"), json(&p));
            cis.insert(format!("sticking_{name}"), json(&ci));
        }
    }
    let mut active = Map::new();
    for (mask, &k) in acc.active_sets.iter().enumerate() {
        active.insert(
            active_set_name(mask, contacts),
            json(&proportion(k, acc.samples).0),
        );
    }
    let mut groups = Map::new();
    groups.insert(
        "all".into(),
        json(&GroupSummary {
            samples: acc.samples,
            impacts: acc.impacts,
            stats,
            fractions,
            fractions_ci95: cis,
            active_sets: active,
        }),
    );
    for (mask, g) in acc.groups.iter().enumerate() {
        if g.samples == 0 || !by_active_set {
            continue;
        }
        let s = headline(
            StatSummary::from_stat(&g.energy_ratio),
            StatSummary::from_stat(&g.omega_after_norm),
            StatSummary::from_stat(&g.velocity_after_norm),
        );
        let name = active_set_name(mask, contacts);
        let key = if name.is_empty() {
            "(none)".to_string()
        } else {
            name
        };
        groups.insert(
            key,
            json(&GroupSummary {
                samples: g.samples,
                impacts: g.impacts,
                stats: s,
                fractions: Map::new(),
                fractions_ci95: Map::new(),
                active_sets: Map::new(),
            }),
        );
    }
    LawSummary { groups }
}

impl Summary {
    pub fn new(scene: &Scene, result: &RunResult) -> Self {
        let contacts: Vec<String> = scene
            .recorded_planes()
            .iter()
            .map(|&i| scene.planes()[i].name.clone())
            .collect();
        let mut laws = Map::new();
        for (law, acc) in scene.laws().iter().zip(&result.acc.laws) {
            let by_set = scene.effects().statistics.by_active_set;
            laws.insert(law.name(), json(&law_summary(acc, &contacts, by_set)));
        }
        // The samples the accumulators hold: the scene's count, except for
        // a shard's share or a partial merge.
        let samples = result.acc.laws.first().map_or(0, |l| l.samples);
        let mut paired = Map::new();
        let first = scene.laws()[0].name();
        for (law, p) in scene.laws().iter().skip(1).zip(&result.acc.pairs) {
            let mut m = headline(
                StatSummary::from_moments(&p.energy_ratio),
                StatSummary::from_moments(&p.omega_after_norm),
                StatSummary::from_moments(&p.velocity_after_norm),
            );
            // Contact scenes: the fraction of samples where one law of the
            // pair raises energy_gain and the other does not.
            if result.acc.drops.is_empty() {
                let (mut only, mut cis) = (Map::new(), Map::new());
                for (name, k) in [
                    (law.name(), p.energy_gain_only),
                    (first.clone(), p.first_energy_gain_only),
                ] {
                    let (f, ci) = proportion(k, samples);
                    only.insert(name.clone(), json(&f));
                    cis.insert(name, json(&ci));
                }
                m.insert("energy_gain_only".into(), serde_json::Value::Object(only));
                m.insert(
                    "energy_gain_only_ci95".into(),
                    serde_json::Value::Object(cis),
                );
            }
            paired.insert(
                format!("{}-{first}", law.name()),
                serde_json::Value::Object(m),
            );
        }
        let mut drops = Map::new();
        for (law, acc) in scene.laws().iter().zip(&result.acc.drops) {
            drops.insert(law.name(), drop_summary(acc, &contacts));
        }
        // Drop scenes run the f64 reference per sample.
        let precision = if drops.is_empty() {
            scene.precision().name()
        } else {
            "f64"
        };
        Summary {
            scene: scene.name().to_string(),
            samples,
            seed: scene.seed(),
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
        }
    }

    /// `summary.laws[law].groups.all`, typed.
    pub fn all_group(&self, law: &str) -> Option<GroupSummary> {
        let v = self.laws.get(law)?.get("groups")?.get("all")?;
        serde_json::from_value(v.clone()).ok()
    }

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
        if self.drops.is_empty() {
            let _ = writeln!(s, "contacts: {}", self.contacts.join(", "));
        } else {
            let _ = writeln!(
                s,
                "drop onto {}; the tables below are each sample's first impact, then its bounces",
                self.contacts.join(", ")
            );
        }
        for law in self.laws.keys() {
            let Some(all) = self.all_group(law) else {
                continue;
            };
            let frac = |k: &str| {
                all.fractions
                    .get(k)
                    .and_then(|v| v.as_f64())
                    .unwrap_or(f64::NAN)
            };
            let _ = writeln!(
                s,
                "\n[{law}] impacts {} of {} ({:.4}); energy_gain {:.2e}, degenerate {:.2e}, jammed {:.2e}, recomputed_f64 {:.2e}, penetrating {:.2e}",
                all.impacts, all.samples, frac("impacting"), frac("energy_gain"), frac("degenerate"), frac("jammed"),
                frac("recomputed_f64"), frac("penetrating")
            );
            let _ = writeln!(
                s,
                "  {:<26} {:>12} {:>10} {:>10} {:>10} {:>10} {:>10}",
                "statistic", "mean", "±95%", "sd", "p01", "median", "p99"
            );
            for (name, v) in &all.stats {
                let Ok(st) = serde_json::from_value::<StatSummary>(v.clone()) else {
                    continue;
                };
                let q = |x: Option<f64>| {
                    x.map(|x| format!("{x:>10.4}"))
                        .unwrap_or_else(|| format!("{:>10}", "-"))
                };
                let _ = writeln!(
                    s,
                    "  {:<26} {:>12.6} {:>10.2e} {:>10.4} {} {} {}",
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
                    format!(
                        "{}={:.4}",
                        if k.is_empty() { "(none)" } else { k },
                        v.as_f64().unwrap_or(f64::NAN)
                    )
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
        for (pair, v) in &self.paired {
            if let Some(er) = v
                .get("energy_ratio")
                .and_then(|x| serde_json::from_value::<StatSummary>(x.clone()).ok())
            {
                let _ = write!(
                    s,
                    "\npaired {pair}: energy_ratio difference {:.6} ± {:.2e} (sd {:.4}, n {})",
                    er.mean, er.ci95, er.sd, er.n
                );
                if let Some(only) = v.get("energy_gain_only").and_then(|x| x.as_object()) {
                    let parts: Vec<String> = only
                        .iter()
                        .map(|(law, f)| {
                            format!("{law} only {:.2e}", f.as_f64().unwrap_or(f64::NAN))
                        })
                        .collect();
                    let _ = write!(s, "; energy_gain in {}", parts.join(", "));
                }
                let _ = writeln!(s);
            }
        }
        s
    }
}

/// The bounce table of one law's [`drop_summary`].
fn drop_text(s: &mut String, d: &serde_json::Value) {
    use std::fmt::Write;
    let f = |k: &str| d.get(k).and_then(|v| v.as_f64()).unwrap_or(f64::NAN);
    let up = |k: &str| {
        d["final_axis_up"]
            .get(k)
            .and_then(|v| v.as_f64())
            .unwrap_or(f64::NAN)
    };
    let _ = writeln!(
        s,
        "  ended: flew away {:.4}, came to rest {:.4}, bounce limit {:.4}, unsolved {:.2e}, stalled {:.2e}; axis closest to vertical at the end: a {:.4}, b {:.4}, c {:.4}",
        f("flew_away"), f("came_to_rest"), f("bounce_limit"), f("unsolved"), f("stalled"),
        up("a"), up("b"), up("c")
    );
    let _ = writeln!(
        s,
        "  {:>6} {:>9} {:>21} {:>13} {:>12}  most frequent planes",
        "bounce", "reached", "T+/T- mean ± ci95", "interval (s)", "speed (m/s)"
    );
    for b in d["bounces"].as_array().into_iter().flatten() {
        let reached = b["reached"].as_u64().unwrap_or(0);
        if reached == 0 {
            continue;
        }
        let mean = |k: &str| b[k]["mean"].as_f64().unwrap_or(f64::NAN);
        let best = b["planes_hit"]
            .as_object()
            .and_then(|m| {
                m.iter()
                    .max_by(|x, y| x.1.as_f64().partial_cmp(&y.1.as_f64()).expect("fractions"))
            })
            .map(|(k, v)| format!("{k} ({:.3})", v.as_f64().unwrap_or(f64::NAN)))
            .unwrap_or_default();
        let _ = writeln!(
            s,
            "  {:>6} {:>9} {:>12.5} ± {:.1e} {:>13.4} {:>12.4}  {best}",
            b["bounce"].as_u64().unwrap_or(0),
            reached,
            mean("energy_ratio"),
            b["energy_ratio"]["ci95"].as_f64().unwrap_or(f64::NAN),
            mean("interval_seconds"),
            mean("speed_before"),
        );
    }
    let seqs = d["sequences"].as_array().map(Vec::as_slice).unwrap_or(&[]);
    let top: Vec<String> = seqs
        .iter()
        .take(5)
        .map(|q| {
            format!(
                "{} {:.4}",
                q["sequence"].as_str().unwrap_or("?"),
                q["fraction"].as_f64().unwrap_or(f64::NAN)
            )
        })
        .collect();
    let _ = writeln!(
        s,
        "  sequences over the first {} impacts (of {}): {}",
        d["sequence_impacts"],
        seqs.len(),
        top.join(";  ")
    );
}
