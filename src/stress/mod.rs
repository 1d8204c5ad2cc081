//! Hard cases, family by family: each family sweeps one parameter over
//! decades and measures, for every law and precision, non-finite results,
//! the error of the fast kernel against the f64 reference on the same
//! inputs, invariant residuals of the reference, and the flags raised.
//! `tests/it/stability.rs` runs a small version with bounds; `impactmc stress`
//! runs a bigger one and prints the table.

use glam::{DMat3, DVec3};

use crate::config::{RawOrientation, RawVector};
mod rows;

use rows::{corner3, corner_scene, kernel_rows, normal, plane, reference_rows, scene, states};
pub use rows::{Row, F32_BOUND, F64_BOUND, LAWS};

use crate::physics::{bryan_from_matrix, matrix_from_bryan, Bryan, Ellipsoid, Plane, Pose};

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
