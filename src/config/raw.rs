//! Scene files as written (TOML, serde, unknown fields rejected). Nothing
//! here is validated beyond its type: [`crate::config::Scene`] does that in
//! one place (ripgrep's raw → validated split).

use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RawScene {
    pub name: String,
    pub samples: u64,
    pub seed: u64,
    /// `paper`, `newton`, `poisson` or `pgsN` (N sweeps).
    pub laws: Vec<String>,
    /// `f32` or `f64`.
    #[serde(default = "default_precision")]
    pub precision: String,
    /// Where the uniforms come from: `mc` (independent draws, the
    /// default) or `rqmc` (`replicates` Owen-scrambled Sobol point sets).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sampling: Option<String>,
    /// RQMC only: independent scrambles of the points (at least 2,
    /// default 16); intervals come from their spread.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub replicates: Option<u64>,
    /// Metres. Default: 1e-9 × the scene's length scale.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact_tolerance: Option<f64>,
    /// Samples per work item of the parallel loop (a power of two). Counts
    /// and histograms do not depend on it; means and variances agree to
    /// rounding (batches are merged in a fixed order, so for a given batch
    /// size the results are bit-identical for any thread count).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub batch_size: Option<u64>,
    pub body: RawBody,
    pub planes: Vec<RawPlane>,
    pub placement: RawPlacement,
    pub orientation: RawOrientation,
    pub velocity: RawVector,
    pub angular_velocity: RawVector,
    /// A grid over numeric scene fields: `"body.semi_axes[2]" = [0.5, 1, 2]`,
    /// `"planes.floor.restitution" = [0.2, 0.5]` (planes by name or index).
    /// Every point uses the same seed (common random numbers).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sweep: Option<toml::Table>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub output: Option<RawOutput>,
    /// Effects beyond those the scene implies: flight, gravity, bounces.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub effects: Option<RawEffects>,
    /// Which statistics a run keeps beyond counts and moments.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub statistics: Option<RawStatistics>,
    /// A precision to reach: the run grows its sample count until it does.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target: Option<RawTarget>,
    /// Contact material, for the compliant reference of `impactmc accuracy`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub material: Option<RawMaterial>,
    /// Knobs of `impactmc accuracy` (the accuracy ladder).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub accuracy: Option<RawAccuracy>,
}

/// A target precision: `ci95 = { energy_ratio = 1e-4 }`, the 95 %
/// half-width each statistic (or fraction) must reach under every law and
/// at every grid point, and the most samples to run for it.
#[derive(Debug, Clone, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RawTarget {
    /// Half-widths by statistic name.
    pub ci95: std::collections::BTreeMap<String, f64>,
    /// The most samples a round may run (default 2^32, or `samples` if
    /// that is more).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_samples: Option<u64>,
}

/// Contact material of the compliant model.
#[derive(Debug, Clone, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RawMaterial {
    /// Effective modulus E* (Pa) of the body–plane pair; steel on steel
    /// (E = 210 GPa, ν = 0.3) is 1.15e11.
    pub effective_modulus: Option<f64>,
}

/// Knobs of the accuracy ladder.
#[derive(Debug, Clone, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RawAccuracy {
    /// Samples on which every rung is compared (the same samples for all).
    pub samples: Option<u64>,
    /// Compliant rungs: RK4 steps per contact duration.
    pub compliant_steps: Option<Vec<u32>>,
    /// The reference: the finest compliant run.
    pub reference_steps: Option<u32>,
    pub pgs_sweeps: Option<Vec<u32>>,
    /// Sample counts of the confidence-interval rung.
    pub sample_counts: Option<Vec<u64>>,
    /// Samples of each law's timing run (one thread, end to end).
    pub timing_samples: Option<u64>,
    /// Drop scenes: RK4 steps of flight rotation to compare (s).
    pub flight_steps: Option<Vec<f64>>,
    /// Drop scenes: time-of-impact tolerances to compare (m).
    pub toi_tolerances: Option<Vec<f64>>,
    /// Compliant rungs with friction: the regularisation ε of Coulomb's law
    /// relative to the velocity scale `|v| + L|ω|` (default 1e-6).
    pub friction_regularisation: Option<f64>,
}

/// Which statistics a run keeps (`[statistics]`). Counts, fractions and
/// the moments (mean, CI, sd, min, max) of every statistic are always kept.
#[derive(Debug, Clone, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RawStatistics {
    /// Statistics whose quantiles (p01, median, p99) and histograms are
    /// kept: any of `energy_ratio`, `omega_after_norm`,
    /// `velocity_after_norm`, `impulse`, `rebound` (per plane). Default:
    /// `energy_ratio` only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub quantiles: Option<Vec<String>>,
    /// Moments and histograms of the post-impact statistics per active
    /// contact set (the `groups` of the summary). Default: false.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub by_active_set: Option<bool>,
}

/// What a run writes beyond the summary tables.
#[derive(Debug, Clone, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RawOutput {
    /// Write `samples.parquet`, one row per sample.
    #[serde(default)]
    pub per_sample: bool,
    /// Per-sample columns to keep (default: all; `sample` always).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub columns: Option<Vec<String>>,
    /// Codec of `samples.parquet`: "zstd" (default), "lz4" or "none".
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub compression: Option<String>,
    /// zstd level, 1..=22 (default 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub level: Option<i32>,
}

fn default_precision() -> String {
    "f32".into()
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RawBody {
    pub semi_axes: [f64; 3],
    pub mass: f64,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RawPlane {
    pub name: String,
    pub normal: [f64; 3],
    pub offset: f64,
    pub restitution: f64,
    /// Coulomb coefficient μ ≥ 0 (absent: 0, frictionless).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<f64>,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RawPlacement {
    /// Names of the planes the body touches; the centre is placed so that
    /// exactly these touch (1 to 3 planes with independent normals).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub touching: Vec<String>,
    /// Instead of `touching`: release the body in flight from a box of
    /// centre positions (uniform; `min = max` for one point).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drop: Option<RawDrop>,
}

#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RawDrop {
    /// Corners of the box of start positions of the centre (m, world).
    pub min: [f64; 3],
    pub max: [f64; 3],
}

/// Effects a scene turns on beyond what its placement implies.
#[derive(Debug, Clone, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RawEffects {
    /// Flight under gravity before (and between) impacts; implied by
    /// `placement.drop`.
    pub flight: Option<bool>,
    /// m/s², acting along −Z. Default 9.81 with flight.
    pub gravity: Option<f64>,
    /// Impacts followed per sample (default 1).
    pub bounces: Option<u32>,
    /// Stop bouncing when the kinetic energy after an impact falls below
    /// this fraction of the kinetic energy at the first impact (default
    /// 1e-4).
    pub energy_floor: Option<f64>,
    /// End a walk whose bounces on one plane accumulate (a Zeno sequence)
    /// as settled on it (default true).
    pub settle: Option<bool>,
    /// Torque-free rotation in flight: "exact" (default: regular
    /// precession for a = b, the elliptic solution otherwise) or "rk4".
    pub flight_rotation: Option<String>,
    /// Largest RK4 step of torque-free rotation (s), with
    /// `flight_rotation = "rk4"`. Default 1e-3.
    pub flight_step: Option<f64>,
    /// Time-of-impact tolerance (m): the advancement stops within it of a
    /// plane. Default: 1e-9 × the scene's length scale (the default contact
    /// tolerance), never above `contact_tolerance`.
    pub toi_tolerance: Option<f64>,
    /// Longest flight searched for the next impact (s). Default 10.
    pub horizon: Option<f64>,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(tag = "distribution", rename_all = "snake_case", deny_unknown_fields)]
pub enum RawOrientation {
    /// Haar measure on SO(3).
    Uniform,
    Fixed {
        bryan_deg: [f64; 3],
    },
    /// ψ, θ, φ independently uniform over degree ranges (not Haar).
    BryanUniform {
        psi_deg: [f64; 2],
        theta_deg: [f64; 2],
        phi_deg: [f64; 2],
    },
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(tag = "distribution", rename_all = "snake_case", deny_unknown_fields)]
pub enum RawVector {
    /// Independent normals per component.
    Normal {
        mean: [f64; 3],
        sd: [f64; 3],
    },
    /// Independent uniforms per component.
    Uniform {
        low: [f64; 3],
        high: [f64; 3],
    },
    Fixed {
        value: [f64; 3],
    },
}

/// Line (1-based) of the value at `path` (e.g. `["planes", "1", "restitution"]`)
/// in a TOML document, found through the parser's spans.
pub fn line_of(text: &str, path: &[&str]) -> Option<usize> {
    use toml::de::{DeTable, DeValue};
    let doc = DeTable::parse(text).ok()?;
    let mut span = doc.span();
    let mut table = Some(doc.get_ref());
    let mut array: Option<&[toml::Spanned<DeValue>]> = None;
    for key in path {
        let value = if let Some(t) = table {
            t.iter()
                .find(|(k, _)| k.get_ref().as_ref() == *key)
                .map(|(_, v)| v)?
        } else {
            let idx: usize = key.parse().ok()?;
            array?.get(idx)?
        };
        span = value.span();
        table = None;
        array = None;
        match value.get_ref() {
            DeValue::Table(t) => table = Some(t),
            DeValue::Array(a) => array = Some(a.as_ref()),
            _ => {}
        }
    }
    Some(text[..span.start.min(text.len())].matches('\n').count() + 1)
}
