//! Hard cases, family by family: each family sweeps one parameter over
//! decades and measures, for every law and precision, non-finite results,
//! the error of the fast kernel against the f64 reference on the same
//! inputs, invariant residuals of the reference, and the flags raised.
//! `tests/it/stability.rs` runs a small version with bounds; `impactmc stress`
//! runs a bigger one and prints the table.

use glam::{DMat3, DVec3};

use crate::config::Scene;
use crate::config::{RawBody, RawOrientation, RawPlacement, RawPlane, RawScene, RawVector};
use crate::engine::evaluate_samples;
use crate::kernel::Status;
use crate::physics::{
    bryan_from_matrix, matrix_from_bryan, solve_impact, Bryan, Ellipsoid, Law, Plane, Pose, State,
};

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

fn plane(name: &str, normal: [f64; 3], offset: f64, k: f64) -> RawPlane {
    RawPlane {
        name: name.into(),
        normal,
        offset,
        restitution: k,
        friction: None,
    }
}

fn corner3(k: [f64; 3]) -> Vec<RawPlane> {
    vec![
        plane("wall_x", [1.0, 0.0, 0.0], 0.0, k[0]),
        plane("wall_y", [0.0, 1.0, 0.0], 0.0, k[1]),
        plane("floor", [0.0, 0.0, 1.0], 0.0, k[2]),
    ]
}

/// A scene built in code (validated like a file).
fn scene(
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
    };
    Scene::validate("(stress)", "", raw).expect("stress scenes are valid")
}

/// S3's corner with a given body, speed scale and restitutions: Haar
/// orientation, v ~ N(−speed, (speed/2)²), ω ~ N(0, 1).
fn corner_scene(semi_axes: [f64; 3], mass: f64, speed: f64, k: [f64; 3], precision: &str) -> Scene {
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

fn normal(mean: [f64; 3], sd: f64) -> RawVector {
    RawVector::Normal { mean, sd: [sd; 3] }
}

/// Kernel rows of a scene: f32 and f64 lanes against the reference on the
/// inputs each drew.
fn kernel_rows(
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
fn kernel_residual(
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
fn reference_rows(
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
fn states(n: usize, speed: f64, spin: f64) -> Vec<State> {
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

/// Runs every family with `samples` samples per case (kernel families) or
/// per state set (reference families).
pub fn run(samples: usize) -> Vec<Row> {
    let mut rows = body_families(samples);
    rows.extend(contact_families(samples));
    rows.extend(reference_families(samples));
    rows
}

/// The body families, in the kernel: aspect ratio, mass and scale.
fn body_families(samples: usize) -> Vec<Row> {
    let mut rows = Vec::new();
    // Aspect ratio c/a over 1e-4 … 1e4, and the sphere.
    for e in -4..=4 {
        let c = 10f64.powi(e);
        let name = if e == 0 {
            "sphere (c/a = 1)".to_string()
        } else {
            format!("c/a = 1e{e}")
        };
        rows.extend(kernel_rows(
            "aspect ratio",
            &name,
            &|p| corner_scene([1.0, 1.0, c], 500.0, 1.0, [0.5, 0.7, 0.9], p),
            samples,
        ));
    }
    // Mass over 1e-6 … 1e6 kg.
    for e in [-6, -3, 0, 3, 6] {
        let m = 10f64.powi(e);
        rows.extend(kernel_rows(
            "mass",
            &format!("m = 1e{e} kg"),
            &|p| corner_scene([1.0, 1.0, 2.0], m, 1.0, [0.5, 0.7, 0.9], p),
            samples,
        ));
    }
    // Scene scale over 1e-6 … 1e6 m (lengths and speeds scaled together).
    for e in [-6, -3, 0, 3, 6] {
        let s = 10f64.powi(e);
        rows.extend(kernel_rows(
            "scale",
            &format!("L = 1e{e} m"),
            &|p| corner_scene([s, s, 2.0 * s], 500.0, s, [0.5, 0.7, 0.9], p),
            samples,
        ));
    }
    rows
}

/// The contact families, in the kernel: gimbal lock, grazing approach,
/// wedges and restitution at its ends.
fn contact_families(samples: usize) -> Vec<Row> {
    let mut rows = Vec::new();
    let uniform = || RawOrientation::Uniform;
    // Gimbal lock: θ = 90° − δ, fixed orientation, random velocities.
    for delta in [0.0, 1e-12, 1e-9, 1e-6, 1e-3] {
        rows.extend(kernel_rows(
            "gimbal lock",
            &format!("θ = 90° − {delta:e}°"),
            &|p| {
                scene(
                    [1.0, 1.5, 2.0],
                    500.0,
                    corner3([0.5, 0.7, 0.9]),
                    RawOrientation::Fixed {
                        bryan_deg: [30.0, 90.0 - delta, 40.0],
                    },
                    normal([-1.0; 3], 0.5),
                    normal([0.0; 3], 1.0),
                    p,
                )
            },
            samples,
        ));
    }
    // Grazing approach: v = (1, 0, −ε) with no spin, so the floor contact's
    // v_n = −ε relative to a unit velocity scale, ε from 1e-12 to 1.
    for e in [-12, -9, -6, -3, 0] {
        let eps = 10f64.powi(e);
        rows.extend(kernel_rows(
            "grazing",
            &format!("v_n = -1e{e}"),
            &|p| {
                scene(
                    [1.0, 1.0, 2.0],
                    500.0,
                    vec![plane("floor", [0.0, 0.0, 1.0], 0.0, 0.8)],
                    uniform(),
                    RawVector::Fixed {
                        value: [1.0, 0.0, -eps],
                    },
                    RawVector::Fixed { value: [0.0; 3] },
                    p,
                )
            },
            samples,
        ));
    }
    // Wedge: two planes whose normals are α apart, α from 1e-4 to 3 rad
    // (smaller α cannot be placed and is in the reference family below).
    for alpha in [1e-4, 1e-2, 1.0, 2.0, 3.0] {
        let (s, c) = (alpha / 2.0f64).sin_cos();
        rows.extend(kernel_rows(
            "wedge",
            &format!("α = {alpha:e} rad"),
            &|p| {
                scene(
                    [1.0, 1.0, 2.0],
                    500.0,
                    vec![
                        plane("left", [s, 0.0, c], 0.0, 0.6),
                        plane("right", [-s, 0.0, c], 0.0, 0.8),
                    ],
                    uniform(),
                    normal([0.0, 0.0, -1.0], 0.5),
                    normal([0.0; 3], 1.0),
                    p,
                )
            },
            samples,
        ));
    }
    // Restitution at exactly 0 and 1, and mixed in one corner.
    for (name, k) in [
        ("k = 0", [0.0; 3]),
        ("k = 1", [1.0; 3]),
        ("mixed 0, 1, 0.5", [0.0, 1.0, 0.5]),
    ] {
        rows.extend(kernel_rows(
            "restitution",
            name,
            &|p| corner_scene([1.0, 1.0, 2.0], 500.0, 1.0, k, p),
            samples,
        ));
    }
    rows
}

/// The reference families: geometry a placement cannot express (wedges
/// closing to parallel, parallel planes, the paper's critical case, boxes
/// of up to six planes).
fn reference_families(samples: usize) -> Vec<Row> {
    let mut rows = Vec::new();
    // Reference families: geometry a placement cannot express.
    let st = states(samples.min(2000), 1.0, 1.0);
    let ell = Ellipsoid::new([1.0, 1.5, 2.0], 3.0).expect("valid");
    let rot = matrix_from_bryan(Bryan {
        psi: 0.3,
        theta: -0.4,
        phi: 1.1,
    });
    let support = |n: DVec3| (ell.semi_axes() * (rot.transpose() * n)).length();
    // A wedge closing to parallel: α from 1e-9 to 1e-5, and exactly 0.
    for alpha in [1e-5, 1e-7, 1e-9, 0.0] {
        let n1 = DVec3::new((alpha / 2.0f64).sin(), 0.0, (alpha / 2.0f64).cos());
        let n2 = DVec3::new(-n1.x, 0.0, n1.z);
        let centre = DVec3::ZERO;
        let planes = [n1, n2].map(|n| Plane::new(n.to_array(), support(n), 0.7).expect("valid"));
        rows.extend(reference_rows(
            "wedge (reference)",
            &format!("α = {alpha:e} rad"),
            &ell,
            Pose {
                rotation: rot,
                centre,
            },
            &st,
            &planes,
        ));
    }
    // Parallel planes: the jammed body (floor and ceiling both touching) and
    // the free one (ceiling 1 m away).
    for (name, gap) in [
        ("jammed between floor and ceiling", 0.0),
        ("floor, ceiling 1 m away", 1.0),
    ] {
        let h = support(DVec3::Z);
        let centre = DVec3::new(0.0, 0.0, h);
        let planes = [
            Plane::new([0.0, 0.0, 1.0], 0.0, 0.8).expect("valid"),
            Plane::new([0.0, 0.0, -1.0], 2.0 * h + gap, 0.6).expect("valid"),
        ];
        rows.extend(reference_rows(
            "parallel planes",
            name,
            &ell,
            Pose {
                rotation: rot,
                centre,
            },
            &st,
            &planes,
        ));
    }
    // The paper's critical case: a sphere jammed between touching floor and
    // ceiling (G singular, no Newton solution with k > 0).
    let sphere = Ellipsoid::new([1.0, 1.0, 1.0], 2.0).expect("valid");
    let planes = [
        Plane::new([0.0, 0.0, 1.0], 0.0, 0.8).expect("valid"),
        Plane::new([0.0, 0.0, -1.0], 2.0, 0.6).expect("valid"),
    ];
    rows.extend(reference_rows(
        "parallel planes",
        "sphere jammed (paper's critical case)",
        &sphere,
        Pose {
            rotation: DMat3::IDENTITY,
            centre: DVec3::Z,
        },
        &st,
        &planes,
    ));
    // Up to six planes: a box around the ellipsoid.
    for faces in [4usize, 5, 6] {
        let centre = DVec3::new(0.2, -0.1, 0.3);
        let planes: Vec<Plane> = (0..faces)
            .map(|f| {
                let mut n = [0.0; 3];
                n[f / 2] = if f % 2 == 0 { 1.0 } else { -1.0 };
                let nv = DVec3::from_array(n);
                Plane::new(n, support(nv) - nv.dot(centre), 0.5).expect("valid")
            })
            .collect();
        rows.extend(reference_rows(
            "box",
            &format!("{faces} faces"),
            &ell,
            Pose {
                rotation: rot,
                centre,
            },
            &st,
            &planes,
        ));
    }
    rows
}

/// Worst matrix → Bryan → matrix round-trip error near θ = ±90°.
pub fn gimbal_round_trip_error() -> f64 {
    let mut worst = 0f64;
    for sign in [-1.0, 1.0] {
        for delta in [0.0, 1e-15, 1e-12, 1e-9, 1e-6, 1e-3] {
            for (psi, phi) in [(0.3, 1.1), (-2.0, 0.4), (3.0, -3.0)] {
                let a = matrix_from_bryan(Bryan {
                    psi,
                    theta: sign * (std::f64::consts::FRAC_PI_2 - delta),
                    phi,
                });
                let back = matrix_from_bryan(bryan_from_matrix(a));
                worst = worst.max(
                    (back - a)
                        .to_cols_array()
                        .iter()
                        .fold(0f64, |m, x| m.max(x.abs())),
                );
            }
        }
    }
    worst
}

/// The table as Markdown.
pub fn table(rows: &[Row]) -> String {
    let mut s = String::from(
        "| family | parameter | law | precision | samples | non-finite | worst error | worst residual | its bound | degenerate | jammed | energy_gain | recomputed f64 |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        s.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {:.1e} | {:.1e} | {:.1e} | {} | {} | {} | {} |\n",
            r.family,
            r.parameter,
            r.law,
            r.precision,
            r.samples,
            r.non_finite,
            r.max_error,
            r.residual,
            r.bound,
            r.degenerate,
            r.jammed,
            r.energy_gain,
            r.recomputed
        ));
    }
    s
}
