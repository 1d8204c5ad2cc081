//! A validated scene: built in one place from a [`RawScene`], with private
//! invariants (a `Scene` that exists can be run). Errors name the file, the
//! field path, its line and the offending value.

use std::path::Path;

use glam::{DMat3, DVec3};

use crate::config::effects::Effects;
use crate::config::plane::NamedPlane;
use crate::config::{line_of, RawScene};
use crate::physics::{Ellipsoid, Law, Plane};

/// Floating-point type of the kernel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Precision {
    F32,
    F64,
}

impl std::str::FromStr for Precision {
    type Err = String;

    /// Parses `f32` or `f64`.
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "f32" => Ok(Self::F32),
            "f64" => Ok(Self::F64),
            other => Err(format!("must be \"f32\" or \"f64\", got {other:?}")),
        }
    }
}

impl Precision {
    /// The precision's name in files and tables: `f32`, `f64`.
    pub fn name(&self) -> &'static str {
        match self {
            Precision::F32 => "f32",
            Precision::F64 => "f64",
        }
    }
}

/// Where a run's uniforms come from (`sampling`, `replicates`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sampling {
    /// Monte Carlo: independent draws of the counter-based generator.
    Mc,
    /// Randomized quasi-Monte Carlo: `replicates` independent Owen
    /// scrambles of the first `2^log2_points` Sobol points; replicate r
    /// holds samples `[r·2^log2_points, (r + 1)·2^log2_points)`.
    Rqmc { replicates: u64, log2_points: u32 },
}

impl Sampling {
    /// Default replicates of `rqmc`.
    pub const DEFAULT_REPLICATES: u64 = 16;

    /// The sampling's name in files and tables: `mc`, `rqmc`.
    pub fn name(&self) -> &'static str {
        match self {
            Sampling::Mc => "mc",
            Sampling::Rqmc { .. } => "rqmc",
        }
    }

    /// RQMC's replicates (none for MC).
    pub fn replicates(&self) -> Option<u64> {
        match *self {
            Sampling::Mc => None,
            Sampling::Rqmc { replicates, .. } => Some(replicates),
        }
    }

    /// RQMC's points per replicate (none for MC).
    pub fn samples_per_replicate(&self) -> Option<u64> {
        match *self {
            Sampling::Mc => None,
            Sampling::Rqmc { log2_points, .. } => Some(1 << log2_points),
        }
    }

    /// The merge-tree level of one replicate over batches of `batch`
    /// samples (a replicate is one node of the tree); none for MC.
    pub fn replicate_level(&self, batch: u64) -> Option<u32> {
        let m = self.samples_per_replicate()?;
        assert!(m % batch == 0, "a replicate is whole batches");
        Some((m / batch).trailing_zeros())
    }
}

/// Orientation distribution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OrientationDist {
    /// Haar measure on SO(3), via uniform unit quaternions.
    Uniform,
    Fixed(DMat3),
    /// Bryan angles (radians) uniform in `[low, high]` per angle (ψ, θ, φ).
    BryanUniform {
        low: DVec3,
        high: DVec3,
    },
}

/// Distribution of a 3-vector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum VectorDist {
    Normal { mean: DVec3, sd: DVec3 },
    Uniform { low: DVec3, high: DVec3 },
    Fixed(DVec3),
}

/// A scene error: where, what, and the value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}{}: {field}: {message}", .line.map(|l| format!(":{l}")).unwrap_or_default())]
pub struct SceneError {
    /// The scene file (or `<string>`, `<dict>`, ...).
    pub file: String,
    /// The line of the field, where the TOML parser knows it.
    pub line: Option<usize>,
    /// The field's dotted path, or the flag.
    pub field: String,
    /// What is wrong, with the value.
    pub message: String,
}

impl SceneError {
    /// The scene file could not be read.
    pub fn io(file: &str, e: &std::io::Error) -> Self {
        Self {
            file: file.to_string(),
            line: None,
            field: "(file)".into(),
            message: e.to_string(),
        }
    }
}

/// Default contact tolerance relative to the scene's length scale.
pub const DEFAULT_TOLERANCE_RELATIVE: f64 = 1e-9;

/// Largest sample count accepted (the sample index is a u64 counter; 2^53
/// keeps every count exact in f64 statistics).
pub const MAX_SAMPLES: u64 = 1 << 53;

/// Largest RQMC replicate: 2^32 points (the Sobol points' digits).
pub const MAX_LOG2_POINTS: u32 = 32;

/// Where every sample of a scene starts: decided once, when the scene is
/// validated. The engine chooses a batch body from it; statistics and rows
/// that one kind of scene has and the other lacks follow from the
/// accumulators and columns that body fills (docs/reference.md).
#[derive(Debug, Clone, PartialEq)]
pub enum Placement {
    /// At contact with one to three planes, the impact at t = 0.
    Contact(Contact),
    /// Released above the planes, flying until it hits them.
    Drop(DropBox),
}

/// A contact placement: the touching planes, and the columns of
/// `Nᵀ (N Nᵀ)⁻¹` that place the centre.
#[derive(Debug, Clone, PartialEq)]
pub struct Contact {
    /// Indices of the touching planes, in scene order.
    pub(super) touching: Vec<usize>,
    /// X0 = Σ_i offsets[i] · (h_i − e_i) over the touching planes.
    pub(super) offsets: Vec<DVec3>,
}

/// A drop placement: the box the centre is released from, uniformly.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DropBox {
    /// The box's lowest corner (m).
    pub low: DVec3,
    /// The box's highest corner (m).
    pub high: DVec3,
}

/// A validated scene: the body, the planes and how the body meets them,
/// the distributions drawn from, the laws, the effects and the statistics.
/// Built by [`load_scene`] or [`SceneText::scene`]; every field has been
/// checked, so a run cannot fail on it.
#[derive(Debug, Clone)]
pub struct Scene {
    pub(super) name: String,
    pub(super) samples: u64,
    pub(super) seed: u64,
    pub(super) laws: Vec<Law>,
    pub(super) precision: Precision,
    pub(super) sampling: Sampling,
    pub(super) tolerance: f64,
    pub(super) batch_size: u64,
    pub(super) body: Ellipsoid,
    pub(super) planes: Vec<NamedPlane>,
    pub(super) placement: Placement,
    pub(super) effects: Effects,
    pub(super) orientation: OrientationDist,
    pub(super) velocity: VectorDist,
    pub(super) angular_velocity: VectorDist,
    pub(super) target: Option<Target>,
    pub(super) raw: RawScene,
}

/// A target precision (`[target]`, validated): the 95 % half-width each
/// named statistic or fraction must reach, and the most samples a round
/// may run.
#[derive(Debug, Clone, PartialEq)]
pub struct Target {
    /// `(name, half-width)`, in name order.
    pub ci95: Vec<(String, f64)>,
    /// At least the scene's `samples`.
    pub max_samples: u64,
}
impl Scene {
    /// Parses scene text into its raw form; a syntax or type error names the
    /// line.
    pub fn parse(file: &str, text: &str) -> Result<RawScene, SceneError> {
        toml::from_str(text).map_err(|e: toml::de::Error| {
            let line = e
                .span()
                .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
            SceneError {
                file: file.to_string(),
                line,
                field: line
                    .and_then(|l| key_at(text, l))
                    .unwrap_or_else(|| "(toml)".into()),
                message: e.message().trim().to_string(),
            }
        })
    }

    /// Validates a raw scene; `text` is the file it came from (for lines).
    pub fn validate(file: &str, text: &str, raw: RawScene) -> Result<Self, SceneError> {
        Self::from_raw(raw).map_err(|b| {
            let path: Vec<&str> = b.path.iter().map(String::as_str).collect();
            let line = (1..=path.len())
                .rev()
                .find_map(|n| line_of(text, &path[..n]));
            let field = b.path.iter().fold(String::new(), |acc, seg| {
                if seg.parse::<usize>().is_ok() {
                    format!("{acc}[{seg}]")
                } else if acc.is_empty() {
                    seg.clone()
                } else {
                    format!("{acc}.{seg}")
                }
            });
            SceneError {
                file: file.to_string(),
                line,
                field,
                message: b.message,
            }
        })
    }

    /// The scene's name.
    pub fn name(&self) -> &str {
        &self.name
    }
    /// Where the samples start.
    pub fn placement(&self) -> &Placement {
        &self.placement
    }
    /// The effects this scene simulates, declared and derived.
    pub fn effects(&self) -> &Effects {
        &self.effects
    }
    /// Samples to run.
    pub fn samples(&self) -> u64 {
        self.samples
    }
    /// The precision to reach, if the scene sets one.
    pub fn target(&self) -> Option<&Target> {
        self.target.as_ref()
    }
    /// The seed of the counter-based draws.
    pub fn seed(&self) -> u64 {
        self.seed
    }
    /// The impact laws, in the order of the summary.
    pub fn laws(&self) -> &[Law] {
        &self.laws
    }
    /// The lanes' precision.
    pub fn precision(&self) -> Precision {
        self.precision
    }
    /// Where the uniforms come from; with RQMC, [`Self::samples`] is
    /// replicates × points per replicate.
    pub fn sampling(&self) -> Sampling {
        self.sampling
    }
    /// Contact tolerance (m): planes this close count as touching.
    pub fn tolerance(&self) -> f64 {
        self.tolerance
    }
    /// Samples per batch (the unit of parallel work and of shards).
    pub fn batch_size(&self) -> u64 {
        self.batch_size
    }
    /// The ellipsoid.
    pub fn body(&self) -> &Ellipsoid {
        &self.body
    }
    /// Every plane, in scene order.
    pub fn planes(&self) -> &[NamedPlane] {
        &self.planes
    }
    /// Indices of the planes the placement makes touch at the start, in
    /// scene order (none for a drop).
    pub fn touching(&self) -> &[usize] {
        match &self.placement {
            Placement::Contact(c) => &c.touching,
            Placement::Drop(_) => &[],
        }
    }
    /// The same body and planes at contact with the planes `touching` (in
    /// scene order, one to three), for the contact kernel: the impacts of a
    /// drop scene, which planes meet at each decided in flight. Only the
    /// kernel's constants are read from it (no centre is placed).
    pub fn contact_view(&self, touching: &[usize]) -> Scene {
        assert!(
            (1..=3).contains(&touching.len()) && touching.windows(2).all(|w| w[0] < w[1]),
            "touching planes {touching:?}"
        );
        let mut view = self.clone();
        let friction = touching
            .iter()
            .any(|&i| self.planes[i].plane.friction() > 0.0);
        view.effects.friction = friction;
        view.effects.flight = false;
        view.placement = Placement::Contact(Contact {
            touching: touching.to_vec(),
            offsets: vec![DVec3::ZERO; touching.len()],
        });
        view
    }
    /// The planes whose impulses a run records, in scene order: the
    /// touching planes of a contact scene, every plane of a drop scene.
    pub fn recorded_planes(&self) -> Vec<usize> {
        match &self.placement {
            Placement::Contact(c) => c.touching.clone(),
            Placement::Drop(_) => (0..self.planes.len()).collect(),
        }
    }
    /// The bounces a run records per sample beyond its first impact's
    /// statistics: `effects.bounces` of a drop, none at contact (its one
    /// impact is the sample).
    pub fn recorded_bounces(&self) -> usize {
        match &self.placement {
            Placement::Contact(_) => 0,
            Placement::Drop(_) => self.effects.bounces as usize,
        }
    }
    /// The touching planes themselves, in scene order.
    pub fn touching_planes(&self) -> Vec<Plane> {
        self.touching()
            .iter()
            .map(|&i| self.planes[i].plane)
            .collect()
    }
    /// The orientation's distribution.
    pub fn orientation(&self) -> OrientationDist {
        self.orientation
    }
    /// The centre velocity's distribution (world, m/s).
    pub fn velocity(&self) -> VectorDist {
        self.velocity
    }
    /// The angular velocity's distribution (body, rad/s).
    pub fn angular_velocity(&self) -> VectorDist {
        self.angular_velocity
    }
    /// The scene as parsed, with every default made explicit.
    pub fn raw(&self) -> &RawScene {
        &self.raw
    }

    /// Centre of the body for rotation `a` (body → world), placed so that the
    /// touching planes touch. With nearly dependent normals the placement
    /// solve amplifies rounding (by 1/λ_min of the normals' Gram matrix), so
    /// one step of iterative refinement on the residuals `h_i − e_i − n_i·X0`
    /// brings the distances back to rounding level.
    ///
    /// A drop scene has no such centre (its centres are drawn in the box):
    /// this is the origin there.
    pub fn centre(&self, a: DMat3) -> DVec3 {
        let Placement::Contact(c) = &self.placement else {
            return DVec3::ZERO;
        };
        // At most three touching planes: fixed arrays, no allocation (this
        // runs per sample when a scene has planes outside the placement).
        let n = c.touching.len();
        let mut targets = [0.0; 3];
        for (t, &i) in targets.iter_mut().zip(&c.touching) {
            let p = &self.planes[i].plane;
            let u = a.transpose() * p.normal();
            *t = (self.body.semi_axes() * u).length() - p.offset();
        }
        let solve =
            |rhs: &[f64; 3]| -> DVec3 { c.offsets.iter().zip(rhs).map(|(col, r)| *col * *r).sum() };
        let mut x = solve(&targets);
        for _ in 0..2 {
            let mut residual = [0.0; 3];
            for k in 0..n {
                residual[k] = targets[k] - self.planes[c.touching[k]].plane.normal().dot(x);
            }
            x += solve(&residual);
        }
        x
    }
}

/// Command-line overrides of scene fields, applied to the raw scene before
/// validation so that they are validated like the file.
#[derive(Debug, Clone, Default)]
pub struct Overrides {
    /// `--per-sample`: write samples.parquet.
    pub per_sample: bool,
    /// `--columns`: per-sample columns to keep.
    pub columns: Option<Vec<String>>,
    /// `--samples`.
    pub samples: Option<u64>,
    /// `--seed`.
    pub seed: Option<u64>,
    /// `--law` (names, each checked against the scene).
    pub laws: Option<Vec<String>>,
    /// `--precision`.
    pub precision: Option<Precision>,
    /// `--quantiles`: replaces `[statistics] quantiles`.
    pub quantiles: Option<Vec<String>>,
    /// `--sampling`: `mc` or `rqmc`.
    pub sampling: Option<String>,
    /// `--replicates`: RQMC's replicates.
    pub replicates: Option<u64>,
    /// `--target-ci STAT=EPS` (repeatable): replaces `[target] ci95`.
    pub target_ci: Option<Vec<(String, f64)>>,
    /// `--max-samples`: `[target] max_samples`.
    pub max_samples: Option<u64>,
}

impl Overrides {
    /// An error of a field these overrides set names the flag that set
    /// it (`--law`, not the scene's line of `laws`).
    pub fn blame(&self, e: SceneError) -> SceneError {
        let root = e.field.split(['[', '.']).next().unwrap_or("");
        let flag = match root {
            "laws" if self.laws.is_some() => "--law",
            "samples" if self.samples.is_some() => "--samples",
            "seed" if self.seed.is_some() => "--seed",
            "precision" if self.precision.is_some() => "--precision",
            "sampling" if self.sampling.is_some() => "--sampling",
            "replicates" if self.replicates.is_some() => "--replicates",
            "statistics" if self.quantiles.is_some() && e.field.contains("quantiles") => {
                "--quantiles"
            }
            "output" if self.columns.is_some() && e.field.contains("columns") => "--columns",
            "target" if self.max_samples.is_some() && e.field.contains("max_samples") => {
                "--max-samples"
            }
            "target" if self.target_ci.is_some() => "--target-ci",
            _ => return e,
        };
        // Keep the element: `--quantiles[1]`, `--law[0]`.
        let element = e.field.find('[').map_or("", |i| &e.field[i..]);
        SceneError {
            line: None,
            field: format!("{flag}{element}"),
            ..e
        }
    }

    /// Writes the overrides into a raw scene, before validation.
    pub fn apply(&self, raw: &mut RawScene) {
        if let Some(s) = self.samples {
            raw.samples = s;
        }
        if let Some(s) = self.seed {
            raw.seed = s;
        }
        if let Some(l) = &self.laws {
            raw.laws = l.clone();
        }
        if let Some(p) = self.precision {
            raw.precision = p.name().to_string();
        }
        if let Some(m) = &self.sampling {
            raw.sampling = Some(m.clone());
            // A change of method drops the scene's replicates, which
            // belonged to the other method (`--replicates` sets them).
            if m != "rqmc" {
                raw.replicates = None;
            }
        }
        if let Some(r) = self.replicates {
            raw.replicates = Some(r);
        }
        if let Some(q) = &self.quantiles {
            let st = raw.statistics.get_or_insert_with(Default::default);
            st.quantiles = Some(q.clone());
        }
        if self.target_ci.is_some() || self.max_samples.is_some() {
            let t = raw.target.get_or_insert_with(Default::default);
            if let Some(c) = &self.target_ci {
                t.ci95 = c.iter().cloned().collect();
            }
            if let Some(m) = self.max_samples {
                t.max_samples = Some(m);
            }
        }
        if self.per_sample || self.columns.is_some() {
            let out = raw.output.get_or_insert_with(Default::default);
            out.per_sample |= self.per_sample;
            if let Some(c) = &self.columns {
                out.columns = Some(c.clone());
            }
        }
    }
}

/// A scene's TOML text and the name its errors give as the file: read
/// from a path, or given as it is (a front end's string).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SceneText {
    /// Where the text came from, for errors.
    pub file: String,
    /// The TOML.
    pub text: String,
}

impl SceneText {
    /// Reads a scene file; an unreadable one is an error of the field
    /// `(file)`.
    pub fn read(path: &Path) -> Result<Self, SceneError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| SceneError::io(&file, &e))?;
        Ok(Self { file, text })
    }

    /// Scene text given as it is; `file` names it in errors (`<string>`).
    #[must_use]
    pub fn new(file: impl Into<String>, text: impl Into<String>) -> Self {
        Self {
            file: file.into(),
            text: text.into(),
        }
    }

    /// The raw scene with the overrides applied.
    pub fn raw(&self, overrides: &Overrides) -> Result<RawScene, SceneError> {
        let mut raw = Scene::parse(&self.file, &self.text)?;
        overrides.apply(&mut raw);
        Ok(raw)
    }

    /// The validated scene (without a sweep: see [`super::sweep::plan`]).
    pub fn scene(&self, overrides: &Overrides) -> Result<Scene, SceneError> {
        Scene::validate(&self.file, &self.text, self.raw(overrides)?)
            .map_err(|e| overrides.blame(e))
    }
}

/// The dotted key a `key = value` line sets (with its table's header),
/// for a type error the TOML parser reports by line only.
fn key_at(text: &str, line: usize) -> Option<String> {
    let lines: Vec<&str> = text.lines().collect();
    let (key, _) = lines.get(line - 1)?.split_once('=')?;
    let key = key.trim();
    if key.is_empty() || key.starts_with(['[', '#']) {
        return None;
    }
    let table = lines[..line - 1]
        .iter()
        .rev()
        .map(|l| l.trim())
        .find(|l| l.starts_with('['))
        .map(|l| l.trim_matches(['[', ']']).trim().to_string());
    Some(match table {
        Some(t) => format!("{t}.{key}"),
        None => key.to_string(),
    })
}

/// Loads a scene file and applies overrides.
pub fn load_scene(path: &Path, overrides: &Overrides) -> Result<Scene, SceneError> {
    SceneText::read(path)?.scene(overrides)
}
