//! A validated scene: built in one place from a [`RawScene`], with private
//! invariants (a `Scene` that exists can be run). Errors name the file, the
//! field path, its line and the offending value.

use std::path::Path;

use glam::{DMat3, DVec3};

use crate::config::{line_of, RawOrientation, RawScene, RawVector};
use crate::physics::{matrix_from_bryan, Bryan, Ellipsoid, Law, Plane, SymMatrix};

/// Floating-point type of the kernel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Precision {
    F32,
    F64,
}

impl Precision {
    pub fn name(&self) -> &'static str {
        match self {
            Precision::F32 => "f32",
            Precision::F64 => "f64",
        }
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

/// A plane with its scene name.
#[derive(Debug, Clone, PartialEq)]
pub struct NamedPlane {
    pub name: String,
    pub plane: Plane,
}

/// A scene error: where, what, and the value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}{}: {field}: {message}", .line.map(|l| format!(":{l}")).unwrap_or_default())]
pub struct SceneError {
    pub file: String,
    pub line: Option<usize>,
    pub field: String,
    pub message: String,
}

/// Default contact tolerance relative to the scene's length scale.
pub const DEFAULT_TOLERANCE_RELATIVE: f64 = 1e-9;

/// Largest sample count accepted (the sample index is a u64 counter; 2^53
/// keeps every count exact in f64 statistics).
pub const MAX_SAMPLES: u64 = 1 << 53;

#[derive(Debug, Clone)]
pub struct Scene {
    name: String,
    samples: u64,
    seed: u64,
    laws: Vec<Law>,
    precision: Precision,
    tolerance: f64,
    batch_size: u64,
    body: Ellipsoid,
    planes: Vec<NamedPlane>,
    touching: Vec<usize>,
    /// X0 = Σ_i placement[i] · (h_i − e_i) over the touching planes.
    placement: Vec<DVec3>,
    /// A drop scene's box of start positions of the centre.
    drop: Option<(DVec3, DVec3)>,
    effects: Effects,
    orientation: OrientationDist,
    velocity: VectorDist,
    angular_velocity: VectorDist,
    raw: RawScene,
}

/// A field error before the file and line are known.
struct Bad {
    path: Vec<String>,
    message: String,
}

fn bad(path: &[&str], message: impl Into<String>) -> Bad {
    Bad {
        path: path.iter().map(|s| s.to_string()).collect(),
        message: message.into(),
    }
}

fn finite3(path: &[&str], v: [f64; 3]) -> Result<DVec3, Bad> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(DVec3::from_array(v))
    } else {
        Err(bad(path, format!("must be finite, got {v:?}")))
    }
}

/// Parses `paper`, `newton`, `poisson`, `pgsN`.
pub fn parse_law(s: &str) -> Option<Law> {
    match s {
        "paper" => Some(Law::Paper),
        "newton" => Some(Law::Newton),
        "poisson" => Some(Law::Poisson),
        _ => {
            let n: u32 = s.strip_prefix("pgs")?.parse().ok()?;
            (n >= 1).then_some(Law::Pgs { sweeps: n })
        }
    }
}

fn vector_dist(field: &str, raw: &RawVector) -> Result<VectorDist, Bad> {
    Ok(match *raw {
        RawVector::Normal { mean, sd } => {
            let mean = finite3(&[field, "mean"], mean)?;
            let sd_v = finite3(&[field, "sd"], sd)?;
            if sd_v.min_element() < 0.0 {
                return Err(bad(&[field, "sd"], format!("must be ≥ 0, got {sd:?}")));
            }
            VectorDist::Normal { mean, sd: sd_v }
        }
        RawVector::Uniform { low, high } => {
            let l = finite3(&[field, "low"], low)?;
            let h = finite3(&[field, "high"], high)?;
            if (0..3).any(|i| l[i] > h[i]) {
                return Err(bad(
                    &[field, "high"],
                    format!("must be ≥ low {low:?}, got {high:?}"),
                ));
            }
            VectorDist::Uniform { low: l, high: h }
        }
        RawVector::Fixed { value } => VectorDist::Fixed(finite3(&[field, "value"], value)?),
    })
}

impl Scene {
    /// Parses scene text into its raw form; a syntax or type error names the
    /// line.
    pub fn parse(file: &str, text: &str) -> Result<RawScene, SceneError> {
        toml::from_str(text).map_err(|e: toml::de::Error| SceneError {
            file: file.to_string(),
            line: e
                .span()
                .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1),
            field: "(toml)".into(),
            message: e.message().trim().to_string(),
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

    fn from_raw(raw: RawScene) -> Result<Self, Bad> {
        if raw.name.trim().is_empty() || raw.name.contains(['/', '\\']) {
            return Err(bad(
                &["name"],
                format!(
                    "must be a non-empty name without slashes, got {:?}",
                    raw.name
                ),
            ));
        }
        if !(1..=MAX_SAMPLES).contains(&raw.samples) {
            return Err(bad(
                &["samples"],
                format!("must be in 1..=2^53, got {}", raw.samples),
            ));
        }
        if raw.laws.is_empty() {
            return Err(bad(&["laws"], "must list at least one law"));
        }
        let mut laws = Vec::new();
        for (i, s) in raw.laws.iter().enumerate() {
            let idx = i.to_string();
            let law = parse_law(s).ok_or_else(|| {
                bad(
                    &["laws", &idx],
                    format!("unknown law {s:?}; expected paper, newton, poisson or pgsN (N ≥ 1)"),
                )
            })?;
            if laws.contains(&law) {
                return Err(bad(&["laws", &idx], format!("law {s:?} is listed twice")));
            }
            laws.push(law);
        }
        let precision = match raw.precision.as_str() {
            "f32" => Precision::F32,
            "f64" => Precision::F64,
            other => {
                return Err(bad(
                    &["precision"],
                    format!("must be \"f32\" or \"f64\", got {other:?}"),
                ))
            }
        };
        let batch_size = raw.batch_size.unwrap_or(65536);
        if !(batch_size.is_power_of_two() && (256..=1 << 22).contains(&batch_size)) {
            return Err(bad(
                &["batch_size"],
                format!("must be a power of two in 256..=4194304, got {batch_size}"),
            ));
        }
        let body = Ellipsoid::new(raw.body.semi_axes, raw.body.mass).map_err(|e| match e {
            crate::physics::BodyError::SemiAxis { .. } => {
                bad(&["body", "semi_axes"], e.to_string())
            }
            crate::physics::BodyError::Mass(_) => bad(&["body", "mass"], e.to_string()),
        })?;
        if raw.planes.is_empty() {
            return Err(bad(&["planes"], "a scene needs at least one plane"));
        }
        let mut planes: Vec<NamedPlane> = Vec::new();
        for (i, p) in raw.planes.iter().enumerate() {
            let idx = i.to_string();
            let plane = Plane::new(p.normal, p.offset, p.restitution).map_err(|e| {
                let f = match e {
                    crate::physics::PlaneError::Normal(_) => "normal",
                    crate::physics::PlaneError::Offset(_) => "offset",
                    crate::physics::PlaneError::Restitution(_) => "restitution",
                };
                bad(&["planes", &idx, f], e.to_string())
            })?;
            if p.name.is_empty() || p.name.contains('+') {
                return Err(bad(
                    &["planes", &idx, "name"],
                    format!("must be non-empty without '+', got {:?}", p.name),
                ));
            }
            if planes.iter().any(|q| q.name == p.name) {
                return Err(bad(
                    &["planes", &idx, "name"],
                    format!("plane name {:?} is used twice", p.name),
                ));
            }
            planes.push(NamedPlane {
                name: p.name.clone(),
                plane,
            });
        }
        let drop = match &raw.placement.drop {
            None => None,
            Some(d) => {
                if !raw.placement.touching.is_empty() {
                    return Err(bad(
                        &["placement"],
                        format!(
                            "give either touching or drop, not both (touching = {:?})",
                            raw.placement.touching
                        ),
                    ));
                }
                let lo = finite3(&["placement", "drop", "min"], d.min)?;
                let hi = finite3(&["placement", "drop", "max"], d.max)?;
                if lo.cmpgt(hi).any() {
                    return Err(bad(
                        &["placement", "drop"],
                        format!(
                            "min must be ≤ max componentwise, got min {:?}, max {:?}",
                            d.min, d.max
                        ),
                    ));
                }
                // Every start must be clear of every plane whatever the
                // orientation: the body fits in a ball of its largest semi-axis.
                let reach = body.length_scale();
                for p in &planes {
                    let n = p.plane.normal();
                    let corner = DVec3::select(n.cmpge(DVec3::ZERO), lo, hi);
                    let d = p.plane.signed_distance(corner);
                    if !(d > reach) {
                        return Err(bad(
                            &["placement", "drop"],
                            format!(
                                "impossible placement: the drop box comes within {d} m of plane {:?} (its corner {:?}), but the body reaches {reach} m from its centre; raw value min {:?}, max {:?}",
                                p.name,
                                corner.to_array(),
                                lo.to_array(),
                                hi.to_array()
                            ),
                        ));
                    }
                }
                Some((lo, hi))
            }
        };
        let (touching, placement) = if drop.is_some() {
            (Vec::new(), Vec::new())
        } else {
            let touching = Self::resolve_touching(&raw, &planes)?;
            let placement = Self::solve_placement(&raw, &planes, &touching)?;
            (touching, placement)
        };
        let length_scale = planes
            .iter()
            .map(|p| p.plane.offset().abs())
            .fold(body.length_scale(), f64::max);
        let tolerance = match raw.contact_tolerance {
            None => DEFAULT_TOLERANCE_RELATIVE * length_scale,
            Some(t) if t.is_finite() && t >= 0.0 => t,
            Some(t) => {
                return Err(bad(
                    &["contact_tolerance"],
                    format!("must be a finite number ≥ 0 (metres), got {t}"),
                ))
            }
        };
        let orientation = match raw.orientation {
            RawOrientation::Uniform => OrientationDist::Uniform,
            RawOrientation::Fixed { bryan_deg } => {
                let d = finite3(&["orientation", "bryan_deg"], bryan_deg)?;
                OrientationDist::Fixed(matrix_from_bryan(Bryan {
                    psi: d.x.to_radians(),
                    theta: d.y.to_radians(),
                    phi: d.z.to_radians(),
                }))
            }
            RawOrientation::BryanUniform {
                psi_deg,
                theta_deg,
                phi_deg,
            } => {
                let mut low = DVec3::ZERO;
                let mut high = DVec3::ZERO;
                for (i, (name, r)) in [
                    ("psi_deg", psi_deg),
                    ("theta_deg", theta_deg),
                    ("phi_deg", phi_deg),
                ]
                .into_iter()
                .enumerate()
                {
                    if !(r[0].is_finite() && r[1].is_finite() && r[0] <= r[1]) {
                        return Err(bad(
                            &["orientation", name],
                            format!("must be a finite [low, high] with low ≤ high, got {r:?}"),
                        ));
                    }
                    low[i] = r[0].to_radians();
                    high[i] = r[1].to_radians();
                }
                OrientationDist::BryanUniform { low, high }
            }
        };
        let effects = Effects::derive(&raw, &body, &planes, &touching, drop.is_some(), tolerance)?;
        let velocity = vector_dist("velocity", &raw.velocity)?;
        let angular_velocity = vector_dist("angular_velocity", &raw.angular_velocity)?;
        Self::check_ranges(&body, precision, velocity, angular_velocity, length_scale)?;
        // Every default made explicit, for the manifest.
        let mut raw = raw;
        raw.contact_tolerance = Some(tolerance);
        raw.batch_size = Some(batch_size);
        Ok(Scene {
            name: raw.name.clone(),
            samples: raw.samples,
            seed: raw.seed,
            laws,
            precision,
            tolerance,
            batch_size,
            body,
            planes,
            touching,
            placement,
            drop,
            effects,
            orientation,
            velocity,
            angular_velocity,
            raw,
        })
    }

    /// Refuses scenes whose quantities overflow or underflow the kernel's
    /// float type: every derived constant (m, 1/m, J, 1/J, a², lengths) and a
    /// generous kinetic-energy scale must be normal numbers, with three
    /// decades of headroom for f32.
    fn check_ranges(
        body: &Ellipsoid,
        precision: Precision,
        velocity: VectorDist,
        omega: VectorDist,
        length_scale: f64,
    ) -> Result<(), Bad> {
        let (lo, hi, kind) = match precision {
            Precision::F32 => (
                f32::MIN_POSITIVE as f64 * 1e3,
                f32::MAX as f64 * 1e-3,
                "the f32 kernel",
            ),
            Precision::F64 => (f64::MIN_POSITIVE * 1e3, f64::MAX * 1e-3, "f64"),
        };
        let j = body.inertia();
        let a = body.semi_axes();
        let constants = [
            body.mass(),
            1.0 / body.mass(),
            j.min_element(),
            j.max_element(),
            1.0 / j.min_element(),
            a.min_element() * a.min_element(),
            a.max_element() * a.max_element(),
            length_scale,
        ];
        if constants.iter().any(|&x| !(x >= lo && x <= hi)) {
            return Err(bad(
                &["body"],
                format!(
                    "mass {} kg and semi-axes {:?} m give quantities beyond the range of {kind} (inertia {:?} kg·m², length scale {length_scale:e} m); use precision = \"f64\" or rescale the units",
                    body.mass(),
                    a.to_array(),
                    j.to_array()
                ),
            ));
        }
        let reach = |d: VectorDist| match d {
            VectorDist::Normal { mean, sd } => mean.abs().max_element() + 40.0 * sd.max_element(),
            VectorDist::Uniform { low, high } => low.abs().max(high.abs()).max_element(),
            VectorDist::Fixed(v) => v.abs().max_element(),
        };
        let (v, w) = (reach(velocity), reach(omega));
        let energy = 0.5 * body.mass() * 3.0 * v * v + 0.5 * j.max_element() * 3.0 * w * w;
        let scale = v + a.max_element() * w;
        if !(energy <= hi && scale <= hi.sqrt()) {
            let field = if 0.5 * body.mass() * 3.0 * v * v > 0.5 * j.max_element() * 3.0 * w * w {
                "velocity"
            } else {
                "angular_velocity"
            };
            return Err(bad(
                &[field],
                format!("speeds up to {v:e} m/s and {w:e} rad/s give kinetic energies up to {energy:e} J, beyond the range of {kind}"),
            ));
        }
        Ok(())
    }

    fn resolve_touching(raw: &RawScene, planes: &[NamedPlane]) -> Result<Vec<usize>, Bad> {
        let names = &raw.placement.touching;
        if names.is_empty() || names.len() > 3 {
            return Err(bad(
                &["placement", "touching"],
                format!("impossible placement: the body can touch 1 to 3 planes with independent normals, got {} ({names:?})", names.len()),
            ));
        }
        let mut idx = Vec::new();
        for (i, n) in names.iter().enumerate() {
            let j = planes.iter().position(|p| &p.name == n).ok_or_else(|| {
                bad(
                    &["placement", "touching", &i.to_string()],
                    format!("no plane is named {n:?}"),
                )
            })?;
            if idx.contains(&j) {
                return Err(bad(
                    &["placement", "touching", &i.to_string()],
                    format!("plane {n:?} is listed twice"),
                ));
            }
            idx.push(j);
        }
        // Scene order, so that active-set names read in scene order.
        idx.sort_unstable();
        Ok(idx)
    }

    /// The minimal-norm centre making the touching planes touch:
    /// `X0 = Nᵀ (N Nᵀ)⁻¹ (h − e)` with N the touching normals as rows.
    fn solve_placement(
        raw: &RawScene,
        planes: &[NamedPlane],
        touching: &[usize],
    ) -> Result<Vec<DVec3>, Bad> {
        let normals: Vec<DVec3> = touching.iter().map(|&i| planes[i].plane.normal()).collect();
        let n = normals.len();
        let mut gram = SymMatrix::zeros(n);
        for i in 0..n {
            for j in 0..n {
                gram.set(i, j, normals[i].dot(normals[j]));
            }
        }
        let min_eig = crate::physics::smallest_eigenvalue_scaled(&gram);
        if !(min_eig > 1e-10) {
            let names: Vec<&str> = touching.iter().map(|&i| planes[i].name.as_str()).collect();
            return Err(bad(
                &["placement", "touching"],
                format!(
                    "impossible placement: the normals of {names:?} are (nearly) dependent (smallest eigenvalue of their Gram matrix {min_eig:e}), so no centre touches them all at once; raw value {:?}",
                    raw.placement.touching
                ),
            ));
        }
        // Columns of Nᵀ (N Nᵀ)⁻¹: solve the Gram system per unit vector.
        let mut cols = Vec::new();
        for i in 0..n {
            let mut e = vec![0.0; n];
            e[i] = 1.0;
            let x = gram
                .solve_spd(&e, 0.0)
                .expect("Gram matrix checked regular");
            cols.push((0..n).map(|j| normals[j] * x[j]).sum::<DVec3>());
        }
        Ok(cols)
    }

    pub fn name(&self) -> &str {
        &self.name
    }
    /// The box of start positions of a drop scene.
    pub fn drop_box(&self) -> Option<(DVec3, DVec3)> {
        self.drop
    }
    /// The effects this scene simulates, declared and derived.
    pub fn effects(&self) -> &Effects {
        &self.effects
    }
    pub fn samples(&self) -> u64 {
        self.samples
    }
    pub fn seed(&self) -> u64 {
        self.seed
    }
    pub fn laws(&self) -> &[Law] {
        &self.laws
    }
    pub fn precision(&self) -> Precision {
        self.precision
    }
    pub fn tolerance(&self) -> f64 {
        self.tolerance
    }
    pub fn batch_size(&self) -> u64 {
        self.batch_size
    }
    pub fn body(&self) -> &Ellipsoid {
        &self.body
    }
    pub fn planes(&self) -> &[NamedPlane] {
        &self.planes
    }
    /// Indices of the planes the placement makes touch, in scene order.
    pub fn touching(&self) -> &[usize] {
        &self.touching
    }
    /// The touching planes themselves, in scene order.
    pub fn touching_planes(&self) -> Vec<Plane> {
        self.touching
            .iter()
            .map(|&i| self.planes[i].plane)
            .collect()
    }
    pub fn orientation(&self) -> OrientationDist {
        self.orientation
    }
    pub fn velocity(&self) -> VectorDist {
        self.velocity
    }
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
    pub fn centre(&self, a: DMat3) -> DVec3 {
        // At most three touching planes: fixed arrays, no allocation (this
        // runs per sample when a scene has planes outside the placement).
        let n = self.touching.len();
        let mut targets = [0.0; 3];
        for (t, &i) in targets.iter_mut().zip(&self.touching) {
            let p = &self.planes[i].plane;
            let u = a.transpose() * p.normal();
            *t = (self.body.semi_axes() * u).length() - p.offset();
        }
        let solve = |rhs: &[f64; 3]| -> DVec3 {
            self.placement
                .iter()
                .zip(rhs)
                .map(|(col, r)| *col * *r)
                .sum()
        };
        let mut x = solve(&targets);
        for _ in 0..2 {
            let mut residual = [0.0; 3];
            for k in 0..n {
                residual[k] = targets[k] - self.planes[self.touching[k]].plane.normal().dot(x);
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
    pub samples: Option<u64>,
    pub seed: Option<u64>,
    pub laws: Option<Vec<String>>,
    pub precision: Option<String>,
    /// `--quantiles`: replaces `[statistics] quantiles`.
    pub quantiles: Option<Vec<String>>,
}

impl Overrides {
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
        if let Some(p) = &self.precision {
            raw.precision = p.clone();
        }
        if let Some(q) = &self.quantiles {
            let st = raw.statistics.get_or_insert_with(Default::default);
            st.quantiles = Some(q.clone());
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

/// Loads a scene file and applies overrides.
pub fn load_scene(path: &Path, overrides: &Overrides) -> Result<Scene, SceneError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| SceneError {
        file: file.clone(),
        line: None,
        field: "(file)".into(),
        message: e.to_string(),
    })?;
    let mut raw = Scene::parse(&file, &text)?;
    overrides.apply(&mut raw);
    Scene::validate(&file, &text, raw)
}

/// What a scene simulates: the effects it declares (`[effects]`, the
/// placement) and those derived from its geometry. Printed at the start of a
/// run and stored in the manifest.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Effects {
    /// Rotation couples to the impulse (false for spheres: ρ = 0, ω is
    /// untouched by impacts).
    pub rotational_coupling: bool,
    /// An LCP couples the contacts (false with one touching plane, or when
    /// G is diagonal by geometry: a sphere on mutually orthogonal planes).
    pub coupled_contacts: bool,
    /// Flight under gravity before and between impacts.
    pub flight: bool,
    pub gravity: f64,
    /// Impacts followed per sample.
    pub bounces: u32,
    pub energy_floor: f64,
    pub flight_step: f64,
    pub toi_tolerance: f64,
    pub horizon: f64,
    /// Torque-free rotation in flight: "none", "precession" (exact, a = b)
    /// or "rk4".
    pub flight_rotation: &'static str,
    /// Per-sample rows requested.
    pub per_sample: bool,
    /// Statistics kept beyond counts and moments (`[statistics]`).
    pub statistics: Statistics,
    /// |ω⁺|, when it is the same in every sample (no rotational coupling and
    /// a fixed ω): counted, not computed per sample.
    pub constant_spin: Option<f64>,
}

/// The statistics a run keeps beyond counts and moments: those not
/// requested are not computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct Statistics {
    /// Quantiles (histograms) of energy_ratio, omega_after_norm,
    /// velocity_after_norm, impulse and rebound, in [`STATISTIC_NAMES`] order.
    pub quantiles: [bool; 5],
    /// Moments and histograms per active contact set.
    pub by_active_set: bool,
}

/// The statistics `[statistics] quantiles` may name.
pub const STATISTIC_NAMES: [&str; 5] = [
    "energy_ratio",
    "omega_after_norm",
    "velocity_after_norm",
    "impulse",
    "rebound",
];

impl Statistics {
    /// Everything: what `--all-effects` computes.
    pub const ALL: Self = Self {
        quantiles: [true; 5],
        by_active_set: true,
    };

    fn from_raw(raw: Option<&crate::config::RawStatistics>) -> Result<Self, Bad> {
        // Default: the energy ratio's, as in the summary of issue #3's JSON
        // interface (means and CIs for |ω⁺| and |v⁺|); each histogram costs
        // about one memory increment per sample (README, Performance).
        let mut quantiles = [true, false, false, false, false];
        if let Some(names) = raw.and_then(|r| r.quantiles.as_ref()) {
            quantiles = [false; 5];
            for (i, n) in names.iter().enumerate() {
                match STATISTIC_NAMES.iter().position(|s| s == n) {
                    Some(k) if quantiles[k] => {
                        return Err(bad(
                            &["statistics", &format!("quantiles[{i}]")],
                            format!("{n:?} is listed twice"),
                        ))
                    }
                    Some(k) => quantiles[k] = true,
                    None => {
                        return Err(bad(
                            &["statistics", &format!("quantiles[{i}]")],
                            format!(
                                "unknown statistic {n:?} (expected one of {})",
                                STATISTIC_NAMES.join(", ")
                            ),
                        ))
                    }
                }
            }
        }
        Ok(Self {
            quantiles,
            by_active_set: raw.and_then(|r| r.by_active_set).unwrap_or(false),
        })
    }

    /// `quantiles of energy_ratio, …; by active set` for the effects line.
    pub fn describe(&self) -> String {
        let q: Vec<&str> = STATISTIC_NAMES
            .iter()
            .zip(self.quantiles)
            .filter_map(|(n, on)| on.then_some(*n))
            .collect();
        let q = if q.is_empty() {
            "no quantiles".to_string()
        } else {
            format!("quantiles of {}", q.join(", "))
        };
        if self.by_active_set {
            format!("{q}; moments per active set")
        } else {
            q
        }
    }
}

impl Effects {
    fn derive(
        raw: &RawScene,
        body: &Ellipsoid,
        planes: &[NamedPlane],
        touching: &[usize],
        drop: bool,
        tolerance: f64,
    ) -> Result<Self, Bad> {
        let e = raw.effects.clone().unwrap_or_default();
        let flight = e.flight.unwrap_or(drop);
        if flight && !drop {
            return Err(bad(
                &["effects", "flight"],
                "flight = true needs placement.drop (a touching placement starts at contact)",
            ));
        }
        if !flight && drop {
            return Err(bad(
                &["effects", "flight"],
                "flight = false contradicts placement.drop",
            ));
        }
        let positive = |path: &[&str], v: Option<f64>, default: f64| -> Result<f64, Bad> {
            let x = v.unwrap_or(default);
            if x.is_finite() && x > 0.0 {
                Ok(x)
            } else {
                Err(bad(path, format!("must be a finite number > 0, got {x}")))
            }
        };
        let gravity = match e.gravity {
            Some(g) if !(g.is_finite() && g >= 0.0) => {
                return Err(bad(
                    &["effects", "gravity"],
                    format!("must be a finite number ≥ 0 (m/s²), got {g}"),
                ))
            }
            Some(g) => g,
            None if flight => 9.81,
            None => 0.0,
        };
        if !flight && (e.gravity.is_some() || e.bounces.is_some()) {
            return Err(bad(
                &["effects"],
                "gravity and bounces need flight (placement.drop)",
            ));
        }
        let bounces = e.bounces.unwrap_or(1);
        if bounces == 0 || bounces > 10_000 {
            return Err(bad(
                &["effects", "bounces"],
                format!("must be in 1..=10000, got {bounces}"),
            ));
        }
        let energy_floor = match e.energy_floor {
            Some(f) if !(f.is_finite() && (0.0..1.0).contains(&f)) => {
                return Err(bad(
                    &["effects", "energy_floor"],
                    format!("must be in [0, 1), got {f}"),
                ))
            }
            Some(f) => f,
            None => 1e-4,
        };
        let flight_step = positive(&["effects", "flight_step"], e.flight_step, 1e-3)?;
        let toi_tolerance = positive(
            &["effects", "toi_tolerance"],
            e.toi_tolerance,
            tolerance.max(1e-12),
        )?;
        if toi_tolerance > tolerance.max(1e-12) {
            return Err(bad(
                &["effects", "toi_tolerance"],
                format!(
                    "must not exceed contact_tolerance ({tolerance:e} m), got {toi_tolerance:e}"
                ),
            ));
        }
        let horizon = positive(&["effects", "horizon"], e.horizon, 10.0)?;
        let s = body.semi_axes();
        let sphere = body.is_sphere();
        let orthogonal = touching.iter().enumerate().all(|(a, &i)| {
            touching[a + 1..]
                .iter()
                .all(|&j| planes[i].plane.normal().dot(planes[j].plane.normal()) == 0.0)
        });
        let coupled = if flight {
            // Which planes meet at an impact is decided in flight.
            planes.len() > 1 && !(sphere && orthogonal_all(planes))
        } else {
            touching.len() > 1 && !(sphere && orthogonal)
        };
        Ok(Self {
            rotational_coupling: !sphere,
            coupled_contacts: coupled,
            flight,
            gravity,
            bounces,
            energy_floor,
            flight_step,
            toi_tolerance,
            horizon,
            flight_rotation: if !flight {
                "none"
            } else if s.x == s.y {
                "precession"
            } else {
                "rk4"
            },
            per_sample: raw.output.as_ref().is_some_and(|o| o.per_sample),
            statistics: Statistics::from_raw(raw.statistics.as_ref())?,
            constant_spin: match (sphere, &raw.angular_velocity) {
                (true, RawVector::Fixed { value }) => Some(DVec3::from_array(*value).length()),
                _ => None,
            },
        })
    }

    /// One line for the terminal.
    pub fn line(&self) -> String {
        let mut on = Vec::new();
        let mut off = Vec::new();
        for (name, x) in [
            ("rotational coupling", self.rotational_coupling),
            ("coupled contacts (LCP)", self.coupled_contacts),
            ("flight", self.flight),
            ("per-sample rows", self.per_sample),
        ] {
            if x {
                on.push(name)
            } else {
                off.push(name)
            }
        }
        let mut s = format!("effects: on [{}]; off [{}]", on.join(", "), off.join(", "));
        if let Some(w) = self.constant_spin {
            s.push_str(&format!("; |ω⁺| = {w} in every sample (not computed)"));
        }
        if self.flight {
            // Drop studies keep their own per-bounce statistics.
            s.push_str(&format!(
                "; gravity {} m/s², up to {} bounce(s), rotation in flight: {}",
                self.gravity, self.bounces, self.flight_rotation
            ));
        } else {
            s.push_str(&format!("; statistics: {}", self.statistics.describe()));
        }
        s
    }
}

fn orthogonal_all(planes: &[NamedPlane]) -> bool {
    planes.iter().enumerate().all(|(a, p)| {
        planes[a + 1..]
            .iter()
            .all(|q| p.plane.normal().dot(q.plane.normal()) == 0.0)
    })
}
