//! `impactmc solve`: one impact case in, one JSON result out.
//!
//! Raw input ([`CaseInput`], serde, unknown fields rejected) is validated in
//! one place ([`Case::from_input`]) into physics types; the output
//! ([`CaseOutput`]) is the public JSON of `impactmc solve` and is also what the
//! golden tests deserialise.

use glam::{DMat3, DQuat, DVec3};
use serde::{Deserialize, Serialize};

use crate::physics::{
    bryan_from_matrix, matrix_from_bryan, matrix_from_quaternion, solve_impact, Bryan, Ellipsoid,
    ImpactOutcome, Law, Plane, Pose, State,
};

/// Default `contact_tolerance`, relative to the case's length scale
/// `max(largest semi-axis, |X0|, largest |offset|)`.
pub const DEFAULT_TOLERANCE_RELATIVE: f64 = 1e-9;

/// A rotation matrix is accepted when `max |AᵀA − I| ≤ this` and det > 0.
pub const ORTHONORMAL_TOLERANCE: f64 = 1e-9;

/// The body of a case.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct BodyInput {
    /// Semi-axes a, b, c (m).
    pub semi_axes: [f64; 3],
    /// Mass (kg).
    pub mass: f64,
}

/// A case's orientation, in one of three forms.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum OrientationInput {
    /// Bryan angles `[ψ, θ, φ]` in degrees, `A = Rx(ψ)Ry(θ)Rz(φ)`.
    BryanDeg([f64; 3]),
    /// `[w, x, y, z]`, normalised on input.
    Quaternion([f64; 4]),
    /// Rows of A (body → world).
    Matrix([[f64; 3]; 3]),
}

/// One plane of a case.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct PlaneInput {
    /// A name for messages (absent: its index).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// The outward normal (normalised on input).
    pub normal: [f64; 3],
    /// The plane is n·x = offset (m).
    pub offset: f64,
    /// Coefficient of restitution k in [0, 1].
    pub restitution: f64,
    /// Coulomb coefficient μ ≥ 0 (absent: 0).
    #[serde(
        default,
        deserialize_with = "friction_value",
        skip_serializing_if = "Option::is_none"
    )]
    pub friction: Option<f64>,
}

/// `friction` as a number; anything else is an error that names the field
/// (serde's own message would not).
fn friction_value<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Number {
        Real(f64),
        Other(serde_json::Value),
    }
    match Number::deserialize(d)? {
        Number::Real(x) => Ok(Some(x)),
        Number::Other(v) => Err(serde::de::Error::custom(format!(
            "planes[].friction must be a number ≥ 0, got {v}"
        ))),
    }
}

/// A case's impact law (`{"pgs": {"sweeps": 8}}`, `"newton"`, ...).
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum LawInput {
    /// The paper's decoupled law.
    Paper,
    /// Newton coupled (an LCP).
    Newton,
    /// Poisson coupled.
    Poisson,
    /// Projected Gauss–Seidel on Newton's LCP.
    Pgs {
        /// Sweeps from λ = 0.
        sweeps: u32,
    },
    /// Energetic restitution with Darboux–Keller integration (one touching
    /// plane).
    Stronge,
}

impl From<LawInput> for Law {
    fn from(l: LawInput) -> Law {
        match l {
            LawInput::Paper => Law::Paper,
            LawInput::Newton => Law::Newton,
            LawInput::Poisson => Law::Poisson,
            LawInput::Pgs { sweeps } => Law::Pgs { sweeps },
            LawInput::Stronge => Law::Stronge,
        }
    }
}

/// The public input of `impactmc solve`.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CaseInput {
    /// The ellipsoid.
    pub body: BodyInput,
    /// Body → world.
    pub orientation: OrientationInput,
    /// The centre, world frame (m).
    pub position: [f64; 3],
    /// The centre velocity before, world frame (m/s).
    pub velocity: [f64; 3],
    /// The angular velocity before, body frame (rad/s).
    pub angular_velocity: [f64; 3],
    /// One to six planes.
    pub planes: Vec<PlaneInput>,
    /// The impact law.
    pub law: LawInput,
    /// Planes this close count as touching (m; absent: 1e-9 of the case's
    /// length scale).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact_tolerance: Option<f64>,
}

/// A bad field: its path in the input, what is wrong, and the value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field}: {message}")]
pub struct FieldError {
    /// The field's path in the input.
    pub field: String,
    /// What is wrong, with the value.
    pub message: String,
}

impl FieldError {
    pub fn new(field: impl Into<String>, message: impl Into<String>) -> Self {
        Self {
            field: field.into(),
            message: message.into(),
        }
    }
}

fn finite3(field: &str, v: [f64; 3]) -> Result<DVec3, FieldError> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(DVec3::from_array(v))
    } else {
        Err(FieldError::new(
            field,
            format!("must be finite, got [{}, {}, {}]", v[0], v[1], v[2]),
        ))
    }
}

/// Rotation from any of the accepted orientation forms, validated.
pub fn rotation_from_input(field: &str, o: &OrientationInput) -> Result<DMat3, FieldError> {
    match *o {
        OrientationInput::BryanDeg(deg) => {
            let d = finite3(&format!("{field}.bryan_deg"), deg)?;
            Ok(matrix_from_bryan(Bryan {
                psi: d.x.to_radians(),
                theta: d.y.to_radians(),
                phi: d.z.to_radians(),
            }))
        }
        OrientationInput::Quaternion(q) => {
            let [w, x, y, z] = q;
            let norm = (w * w + x * x + y * y + z * z).sqrt();
            if !(norm.is_finite() && norm > 0.0) {
                return Err(FieldError::new(
                    format!("{field}.quaternion"),
                    format!("must be a finite non-zero quaternion, got [{w}, {x}, {y}, {z}]"),
                ));
            }
            Ok(matrix_from_quaternion(DQuat::from_xyzw(x, y, z, w)))
        }
        OrientationInput::Matrix(rows) => {
            let f = format!("{field}.matrix");
            for (i, r) in rows.iter().enumerate() {
                finite3(&format!("{f}[{i}]"), *r)?;
            }
            let a = DMat3::from_cols_array_2d(&rows).transpose();
            let err = (a.transpose() * a - DMat3::IDENTITY)
                .to_cols_array()
                .iter()
                .fold(0f64, |m, x| m.max(x.abs()));
            let det = a.determinant();
            if !(err <= ORTHONORMAL_TOLERANCE && det > 0.0) {
                return Err(FieldError::new(
                    f,
                    format!(
                        "must be a rotation (orthonormal rows, det = +1); max |AᵀA − I| = {err:e}, det = {det}, got {rows:?}"
                    ),
                ));
            }
            Ok(a)
        }
    }
}

/// A validated case: every value that exists is usable.
#[derive(Debug, Clone)]
pub struct Case {
    pub body: Ellipsoid,
    pub pose: Pose,
    pub state: State,
    pub planes: Vec<Plane>,
    pub law: Law,
    pub tolerance: f64,
}

impl Case {
    pub fn from_input(input: &CaseInput) -> Result<Self, FieldError> {
        let body = Ellipsoid::new(input.body.semi_axes, input.body.mass).map_err(|e| {
            let field = match e {
                crate::physics::BodyError::SemiAxis { .. } => "body.semi_axes",
                crate::physics::BodyError::Mass(_) => "body.mass",
            };
            FieldError::new(field, e.to_string())
        })?;
        let rotation = rotation_from_input("orientation", &input.orientation)?;
        let centre = finite3("position", input.position)?;
        let velocity = finite3("velocity", input.velocity)?;
        let omega = finite3("angular_velocity", input.angular_velocity)?;
        let planes = input
            .planes
            .iter()
            .enumerate()
            .map(|(i, p)| {
                Plane::new(p.normal, p.offset, p.restitution)
                    .and_then(|q| q.with_friction(p.friction.unwrap_or(0.0)))
                    .map_err(|e| {
                        FieldError::new(format!("planes[{i}].{}", e.field()), e.to_string())
                    })
            })
            .collect::<Result<Vec<_>, _>>()?;
        if let LawInput::Pgs { sweeps: 0 } = input.law {
            return Err(FieldError::new("law.pgs.sweeps", "must be ≥ 1, got 0"));
        }
        let tolerance = match input.contact_tolerance {
            Some(t) if t.is_finite() && t >= 0.0 => t,
            Some(t) => {
                return Err(FieldError::new(
                    "contact_tolerance",
                    format!("must be a finite number ≥ 0 (metres), got {t}"),
                ))
            }
            None => {
                let scale = planes
                    .iter()
                    .map(|p| p.offset().abs())
                    .fold(body.length_scale().max(centre.length()), f64::max);
                DEFAULT_TOLERANCE_RELATIVE * scale
            }
        };
        Ok(Case {
            body,
            pose: Pose { rotation, centre },
            state: State { velocity, omega },
            planes,
            law: input.law.into(),
            tolerance,
        })
    }

    /// Solves the case. The only failure is more touching contacts than the
    /// exact LCP accepts, reported against `planes`.
    pub fn solve(&self) -> Result<CaseOutput, FieldError> {
        let outcome = solve_impact(
            &self.body,
            self.pose,
            self.state,
            &self.planes,
            self.law,
            self.tolerance,
        )
        .map_err(|e| FieldError::new("planes", e.to_string()))?;
        let out = CaseOutput::new(self, &outcome);
        // Finite inputs can still overflow f64 (a velocity of 1e308 squares to
        // infinity; a subnormal mass has an infinite inverse). Such a case is
        // refused, never answered with inf or NaN.
        let finite = out
            .velocity
            .iter()
            .chain(&out.angular_velocity)
            .all(|x| x.is_finite())
            && out.energy_before.is_finite()
            && out.energy_after.is_finite()
            && out.contacts.iter().all(|c| {
                c.point.iter().all(|x| x.is_finite())
                    && c.distance.is_finite()
                    && c.impulse.is_finite()
                    && c.normal_velocity_before.is_finite()
                    && c.normal_velocity_after.is_finite()
            });
        if !finite {
            return Err(FieldError::new(
                "(case)",
                format!(
                    "the result overflows f64: mass {}, semi-axes {:?}, |v| {:e}, |ω| {:e}, |position| {:e} are too extreme together",
                    self.body.mass(),
                    self.body.semi_axes().to_array(),
                    self.state.velocity.length(),
                    self.state.omega.length(),
                    self.pose.centre.length()
                ),
            ));
        }
        Ok(out)
    }
}

/// One contact in the output, per plane in input order.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
pub struct ContactOutput {
    /// The plane's index in the input.
    pub plane: usize,
    /// World contact point (m).
    pub point: [f64; 3],
    /// Signed distance (m).
    pub distance: f64,
    /// Within the contact tolerance.
    pub touching: bool,
    /// Touching and `v_n < 0` before.
    pub approaching: bool,
    /// v_n before (m/s).
    pub normal_velocity_before: f64,
    /// Impulse λ (N·s).
    pub impulse: f64,
    /// v_n after (m/s).
    pub normal_velocity_after: f64,
    /// Tangential impulse `f = P − λn`, world frame (N·s); zero without
    /// friction.
    #[serde(default)]
    pub tangential_impulse: [f64; 3],
    /// Active (λ > 0) and `|c⁺_t| ≤ 1e-9 ×` the velocity scale (the larger
    /// of `|v| + L|ω|` before and after). In expected files, absent or
    /// null means not compared.
    #[serde(default)]
    pub sticking: Option<bool>,
    /// `|c⁺_t|`, the contact point's tangential speed after (m/s). Extra
    /// field.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sliding_speed_after: Option<f64>,
    /// Lever arm ρ in the body frame (m). Extra field.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lever_arm: Option<[f64; 3]>,
    /// Support distance h (m). Extra field.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub support_distance: Option<f64>,
}

/// The public output of `impactmc solve`.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
pub struct CaseOutput {
    /// Per plane, in input order.
    pub contacts: Vec<ContactOutput>,
    /// Post-impact centre velocity, world frame (m/s).
    pub velocity: [f64; 3],
    /// Post-impact angular velocity, body frame (rad/s).
    pub angular_velocity: [f64; 3],
    /// Kinetic energy before (J).
    pub energy_before: f64,
    /// Kinetic energy after (J).
    pub energy_after: f64,
    /// `energy_gain`, `degenerate`, `jammed`, `unsolved`.
    pub flags: Vec<String>,
    /// Extra fields: the law used, the tolerance applied, the Bryan angles
    /// of the orientation (deg), and the smallest eigenvalue of the scaled G.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub law: Option<String>,
    /// The contact tolerance applied (m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact_tolerance: Option<f64>,
    /// The orientation's Bryan angles (deg).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bryan_deg: Option<[f64; 3]>,
    /// The smallest eigenvalue of the scaled G.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_eigenvalue_scaled: Option<f64>,
}

impl CaseOutput {
    fn new(case: &Case, o: &ImpactOutcome) -> Self {
        let length = case.body.length_scale();
        let vscale = (case.state.velocity.length() + length * case.state.omega.length())
            .max(o.after.velocity.length() + length * o.after.omega.length());
        let contacts = o
            .contacts
            .iter()
            .enumerate()
            .map(|(i, c)| ContactOutput {
                plane: i,
                point: c.geometry.point.to_array(),
                distance: c.geometry.distance,
                touching: c.touching,
                approaching: c.approaching,
                normal_velocity_before: c.normal_velocity_before,
                impulse: c.impulse,
                normal_velocity_after: c.normal_velocity_after,
                tangential_impulse: c.tangential_impulse.to_array(),
                sticking: Some(c.impulse > 0.0 && c.sliding_after <= 1e-9 * vscale),
                sliding_speed_after: Some(c.sliding_after),
                lever_arm: Some(c.geometry.lever.to_array()),
                support_distance: Some(c.geometry.support),
            })
            .collect();
        let mut flags = Vec::new();
        for (on, name) in [
            (o.flags.energy_gain, "energy_gain"),
            (o.flags.degenerate, "degenerate"),
            (o.flags.jammed, "jammed"),
            (o.flags.unsolved, "unsolved"),
            (o.flags.ambiguous, "ambiguous"),
            (o.flags.unconverged, "unconverged"),
        ] {
            if on {
                flags.push(name.to_string());
            }
        }
        let b = bryan_from_matrix(case.pose.rotation);
        CaseOutput {
            contacts,
            velocity: o.after.velocity.to_array(),
            angular_velocity: o.after.omega.to_array(),
            energy_before: o.energy_before,
            energy_after: o.energy_after,
            flags,
            law: Some(case.law.name()),
            contact_tolerance: Some(case.tolerance),
            bryan_deg: Some([b.psi.to_degrees(), b.theta.to_degrees(), b.phi.to_degrees()]),
            min_eigenvalue_scaled: Some(o.min_eigenvalue),
        }
    }
}

/// Why a case was not solved: the input's name (a file, `stdin`,
/// `<string>`), the field when one is at fault, and what is wrong. Its text
/// is what every front end prints.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{name}: {}{message}", field.as_ref().map(|f| format!("{f}: ")).unwrap_or_default())]
pub struct CaseError {
    /// The input's name.
    pub name: String,
    /// The field at fault, when one is.
    pub field: Option<String>,
    /// What is wrong.
    pub message: String,
}

/// Parses, validates and solves one case: what `impactmc solve` prints.
/// `json` as in [`parse_case`]; `name` names the input in errors.
pub fn solve_text(name: &str, text: &str, json: Option<bool>) -> Result<CaseOutput, CaseError> {
    let input = parse_case(text, json).map_err(|message| CaseError {
        name: name.to_string(),
        field: None,
        message,
    })?;
    let by_field = |e: FieldError| CaseError {
        name: name.to_string(),
        field: Some(e.field),
        message: e.message,
    };
    Case::from_input(&input)
        .map_err(by_field)?
        .solve()
        .map_err(by_field)
}

/// Parses a case from JSON or TOML text. `json` chooses the format; with
/// `None` the text is JSON when its first non-blank character is `{`.
pub fn parse_case(text: &str, json: Option<bool>) -> Result<CaseInput, String> {
    let is_json = json.unwrap_or_else(|| text.trim_start().starts_with('{'));
    if is_json {
        serde_json::from_str(text).map_err(|e| format!("invalid case JSON: {e}"))
    } else {
        toml::from_str(text).map_err(|e| format!("invalid case TOML: {e}"))
    }
}
