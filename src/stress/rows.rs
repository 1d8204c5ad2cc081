//! A family's rows: per case, the lane kernel against the f64 reference on
//! the same inputs (kernel rows), or the reference's invariants alone
//! (reference rows), and the scenes the families build.

use glam::{DMat3, DVec3};

use crate::config::Scene;
use crate::config::{RawBody, RawOrientation, RawPlacement, RawPlane, RawScene, RawVector};
use crate::engine::evaluate_samples;
use crate::kernel::Status;
use crate::physics::{solve_impact, Ellipsoid, Law, Plane, Pose, State};

/// Laws every family is run under.
pub const LAWS: [Law; 4] = [
    Law::Paper,
    Law::Newton,
    Law::Poisson,
    Law::Pgs { sweeps: 8 },
];

/// Documented bound of the f32 kernel, as a fraction of the velocity scale
/// `|v| + L|ω|`, on lanes it does not hand to the f64 reference.
pub const F32_BOUND: f64 = 1e-5;
/// Bound of the f64 kernel against the reference.
pub const F64_BOUND: f64 = 1e-12;

/// One (family, parameter, law, precision) line of the table.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    pub family: &'static str,
    pub parameter: String,
    pub law: String,
    /// "f32", "f64" (lane kernel) or "ref" (the f64 reference alone).
    pub precision: &'static str,
    pub samples: usize,
    pub non_finite: usize,
    /// Worst error against the f64 reference, relative to the velocity
    /// scale (kernel rows), or worst invariant residual (reference rows).
    pub max_error: f64,
    /// The bound at the sample where `error / bound` is worst. Kernel rows:
    /// the base bound of the precision plus `16 ε N / λ_min(S)`, i.e. the
    /// rounding an N-contact solve amplifies by the condition of the
    /// unit-diagonal G (λ_max(S) ≤ N).
    pub bound: f64,
    /// Worst `error / bound` over the samples; the row passes when ≤ 1.
    pub worst_ratio: f64,
    /// Kernel rows: worst invariant residual of the kernel's own answer,
    /// relative to the velocity scale: momentum change off the span of the
    /// touching normals, and for Newton `|v_n⁺ + k v_n⁻|` on active
    /// approaching contacts. Judged against the same per-sample bound.
    pub residual: f64,
    pub degenerate: usize,
    pub jammed: usize,
    pub energy_gain: usize,
    pub recomputed: usize,
}

impl Row {
    pub fn within_bound(&self) -> bool {
        self.non_finite == 0 && self.worst_ratio <= 1.0
    }
}

pub(super) fn plane(name: &str, normal: [f64; 3], offset: f64, k: f64) -> RawPlane {
    RawPlane {
        name: name.into(),
        normal,
        offset,
        restitution: k,
        friction: None,
    }
}

pub(super) fn corner3(k: [f64; 3]) -> Vec<RawPlane> {
    vec![
        plane("wall_x", [1.0, 0.0, 0.0], 0.0, k[0]),
        plane("wall_y", [0.0, 1.0, 0.0], 0.0, k[1]),
        plane("floor", [0.0, 0.0, 1.0], 0.0, k[2]),
    ]
}

/// A scene built in code (validated like a file).
pub(super) fn scene(
    semi_axes: [f64; 3],
    mass: f64,
    planes: Vec<RawPlane>,
    orientation: RawOrientation,
    velocity: RawVector,
    omega: RawVector,
    precision: &str,
) -> Scene {
    let touching = planes.iter().map(|p| p.name.clone()).collect();
    let raw = RawScene {
        name: "stress".into(),
        samples: 1,
        seed: 11,
        laws: vec!["newton".into()],
        precision: precision.into(),
        sampling: None,
        replicates: None,
        contact_tolerance: None,
        batch_size: None,
        body: RawBody { semi_axes, mass },
        planes,
        placement: RawPlacement {
            touching,
            drop: None,
        },
        orientation,
        velocity,
        angular_velocity: omega,
        sweep: None,
        output: None,
        material: None,
        accuracy: None,
        effects: None,
        statistics: None,
        target: None,
    };
    Scene::validate("(stress)", "", raw).expect("stress scenes are valid")
}

/// S3's corner with a given body, speed scale and restitutions: Haar
/// orientation, v ~ N(−speed, (speed/2)²), ω ~ N(0, 1).
pub(super) fn corner_scene(
    semi_axes: [f64; 3],
    mass: f64,
    speed: f64,
    k: [f64; 3],
    precision: &str,
) -> Scene {
    scene(
        semi_axes,
        mass,
        corner3(k),
        RawOrientation::Uniform,
        normal([-speed; 3], 0.5 * speed),
        normal([0.0; 3], 1.0),
        precision,
    )
}

pub(super) fn normal(mean: [f64; 3], sd: f64) -> RawVector {
    RawVector::Normal { mean, sd: [sd; 3] }
}

/// Kernel rows of a scene: f32 and f64 lanes against the reference on the
/// inputs each drew.
pub(super) fn kernel_rows(
    family: &'static str,
    parameter: &str,
    make: &dyn Fn(&str) -> Scene,
    samples: usize,
) -> Vec<Row> {
    let mut rows = Vec::new();
    for precision in ["f32", "f64"] {
        let s = make(precision);
        let planes: Vec<Plane> = s.planes().iter().map(|p| p.plane).collect();
        let l = s.body().length_scale();
        for law in LAWS {
            let mut row = Row {
                family,
                parameter: parameter.to_string(),
                law: law.name(),
                precision: if precision == "f32" { "f32" } else { "f64" },
                samples,
                non_finite: 0,
                max_error: 0.0,
                bound: if precision == "f32" {
                    F32_BOUND
                } else {
                    F64_BOUND
                },
                worst_ratio: 0.0,
                residual: 0.0,
                degenerate: 0,
                jammed: 0,
                energy_gain: 0,
                recomputed: 0,
            };
            for got in evaluate_samples(&s, law, 0, samples) {
                let a = DMat3::from_cols_array(&got.rotation).transpose();
                let (v, w) = (
                    DVec3::from_array(got.velocity),
                    DVec3::from_array(got.omega),
                );
                let finite = got
                    .velocity_after
                    .iter()
                    .chain(&got.omega_after)
                    .all(|x| x.is_finite())
                    && got.energy_after.is_finite()
                    && got.impulses.iter().all(|x| x.is_finite());
                if !finite {
                    row.non_finite += 1;
                    continue;
                }
                let want = solve_impact(
                    s.body(),
                    Pose {
                        rotation: a,
                        centre: s.centre(a),
                    },
                    State {
                        velocity: v,
                        omega: w,
                    },
                    &planes,
                    law,
                    s.tolerance(),
                )
                .expect("≤ 16 contacts");
                let scale = v.length() + l * w.length();
                if scale > 0.0 {
                    let dv = (DVec3::from_array(got.velocity_after) - want.after.velocity).length();
                    let dw = (DVec3::from_array(got.omega_after) - want.after.omega).length() * l;
                    let err = dv.max(dw) / scale;
                    let (base, eps) = if precision == "f32" {
                        (F32_BOUND, f32::EPSILON as f64)
                    } else {
                        (F64_BOUND, f64::EPSILON)
                    };
                    let n = s.touching().len() as f64;
                    let bound = base + 16.0 * eps * n / want.min_eigenvalue.max(f64::MIN_POSITIVE);
                    row.max_error = row.max_error.max(err);
                    let residual = kernel_residual(&s, law, &got, &want, scale);
                    row.residual = row.residual.max(residual);
                    let worst = err.max(residual) / bound;
                    if worst > row.worst_ratio {
                        row.worst_ratio = worst;
                        row.bound = bound;
                    }
                }
                row.degenerate += (got.status.has(Status::DEGENERATE)) as usize;
                row.jammed += (got.status.has(Status::JAMMED)) as usize;
                row.energy_gain += (got.status.has(Status::ENERGY_GAIN)) as usize;
                row.recomputed += (got.status.has(Status::RECOMPUTED)) as usize;
            }
            rows.push(row);
        }
    }
    rows
}

/// Invariant residuals of one kernel answer (see [`Row::residual`]).
pub(super) fn kernel_residual(
    s: &Scene,
    law: Law,
    got: &crate::engine::SampleOutcome,
    want: &crate::physics::ImpactOutcome,
    scale: f64,
) -> f64 {
    if scale == 0.0 {
        return 0.0;
    }
    let normals: Vec<DVec3> = s
        .touching()
        .iter()
        .map(|&i| s.planes()[i].plane.normal())
        .collect();
    let v0 = DVec3::from_array(got.velocity);
    let v1 = DVec3::from_array(got.velocity_after);
    let w1 = DVec3::from_array(got.omega_after);
    let dv = v1 - v0;
    // Momentum: Δv must lie in the span of the touching normals.
    let off = match normals.len() {
        1 => (dv - normals[0] * normals[0].dot(dv)).length(),
        2 => {
            let m = normals[0].cross(normals[1]).normalize_or_zero();
            m.dot(dv).abs()
        }
        _ => 0.0,
    };
    let mut r = off / scale;
    if law == Law::Newton && !got.status.has(Status::RECOMPUTED) {
        for (i, &p) in s.touching().iter().enumerate() {
            let c = &want.contacts[p];
            if c.approaching && got.impulses[i] > 1e-9 * s.body().mass() * scale {
                let vn_after = normals[i].dot(v1) + c.geometry.lever.dot(w1);
                let k = s.planes()[p].plane.restitution();
                r = r.max((vn_after + k * c.normal_velocity_before).abs() / scale);
            }
        }
    }
    r
}

/// Reference rows of a hand-built case: non-finite results and the
/// invariant residual (no contact ends penetrating under Newton and
/// Poisson; for Newton, active approaching contacts rebound at −k v_n),
/// relative to the velocity scale.
pub(super) fn reference_rows(
    family: &'static str,
    parameter: &str,
    body: &Ellipsoid,
    pose: Pose,
    states: &[State],
    planes: &[Plane],
) -> Vec<Row> {
    let l = body.length_scale();
    let tol = 1e-9 * l.max(pose.centre.length());
    LAWS.iter()
        .map(|&law| {
            let mut row = Row {
                family,
                parameter: parameter.to_string(),
                law: law.name(),
                precision: "ref",
                samples: states.len(),
                non_finite: 0,
                max_error: 0.0,
                bound: 1e-9,
                worst_ratio: 0.0,
                residual: 0.0,
                degenerate: 0,
                jammed: 0,
                energy_gain: 0,
                recomputed: 0,
            };
            for &st in states {
                let o = solve_impact(body, pose, st, planes, law, tol).expect("≤ 16 contacts");
                if !(o.after.velocity.is_finite()
                    && o.after.omega.is_finite()
                    && o.energy_after.is_finite())
                {
                    row.non_finite += 1;
                    continue;
                }
                row.degenerate += o.flags.degenerate as usize;
                row.jammed += o.flags.jammed as usize;
                row.energy_gain += o.flags.energy_gain as usize;
                let scale = (st.velocity.length() + l * st.omega.length()).max(f64::MIN_POSITIVE);
                if matches!(law, Law::Newton | Law::Poisson) {
                    for c in o.contacts.iter().filter(|c| c.touching) {
                        row.max_error = row.max_error.max(-c.normal_velocity_after / scale);
                    }
                }
                if law == Law::Newton && !o.flags.jammed && !o.flags.degenerate {
                    for (c, p) in o.contacts.iter().zip(planes) {
                        if c.approaching && c.impulse > 0.0 {
                            let want = -p.restitution() * c.normal_velocity_before;
                            row.max_error = row
                                .max_error
                                .max((c.normal_velocity_after - want).abs() / scale);
                        }
                    }
                }
            }
            row.worst_ratio = row.max_error / row.bound;
            row
        })
        .collect()
}

/// Deterministic pseudo-random states for reference families.
pub(super) fn states(n: usize, speed: f64, spin: f64) -> Vec<State> {
    (0..n)
        .map(|i| {
            let f = |j: u64| {
                let x = crate::sampler::rng::mix64(i as u64 * 8 + j);
                (x >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
            };
            State {
                velocity: DVec3::new(f(0), f(1), f(2)) * speed,
                omega: DVec3::new(f(3), f(4), f(5)) * spin,
            }
        })
        .collect()
}
