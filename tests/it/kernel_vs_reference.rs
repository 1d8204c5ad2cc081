//! The SoA lane kernel against the pure f64 reference in `physics/`, sample
//! by sample, on the canonical scenes: f64 to 1e-12 of the velocity scale,
//! f32 within the documented bound (README, "Precision").

use crate::support;

use glam::{DMat3, DVec3};
use impactmc::config::Scene;
use impactmc::engine::evaluate_samples;
use impactmc::kernel::Status;
use impactmc::physics::{solve_impact, Law, Pose, State};
use impactmc::sampler::Sampler;

const SCENES: [&str; 3] = ["floor", "corner2_paper", "corner3"];
const LAWS: [Law; 5] = [
    Law::Paper,
    Law::Newton,
    Law::Poisson,
    Law::Pgs { sweeps: 1 },
    Law::Pgs { sweeps: 8 },
];

/// Documented bound of the f32 kernel: post-impact velocities within this
/// fraction of the velocity scale |v| + L|ω| of the f64 reference.
pub const F32_VELOCITY_BOUND: f64 = 1e-5;

fn scene(name: &str, precision: &str) -> Scene {
    support::shipped_scene(name, precision)
}

/// Worst error (relative to the velocity scale) of the kernel against the
/// reference over `count` samples, and how many lanes were recomputed.
fn worst_error(scene: &Scene, law: Law, first: u64, count: usize) -> (f64, usize) {
    let sampler = Sampler::new(scene);
    let planes: Vec<_> = scene.planes().iter().map(|p| p.plane).collect();
    let l = scene.body().length_scale();
    let mut worst = 0f64;
    let mut recomputed = 0;
    let f64_kernel = scene.precision().name() == "f64";
    for got in evaluate_samples(scene, law, first, count) {
        let (ra, rv, rw) = sampler.reference(got.index);
        let ga = DMat3::from_cols_array(&got.rotation).transpose();
        let (gv, gw) = (
            DVec3::from_array(got.velocity),
            DVec3::from_array(got.omega),
        );
        // The drawn inputs match the reference sampler: to rounding in f64;
        // in f32 up to the quantisation of 23-bit uniforms, which Box–Muller
        // magnifies in the far tails.
        let input_err = (ga - ra)
            .to_cols_array()
            .iter()
            .fold(0f64, |m, x| m.max(x.abs()))
            .max((gv - rv).abs().max_element())
            .max((gw - rw).abs().max_element());
        let input_bound = if f64_kernel { 1e-13 } else { 1e-3 };
        assert!(
            input_err < input_bound,
            "sample {} inputs differ by {input_err:e}",
            got.index
        );
        // The kernel is judged on the inputs it drew (in f32, rounded ones).
        let (a, v, w) = if f64_kernel {
            (ra, rv, rw)
        } else {
            (ga, gv, gw)
        };
        let pose = Pose {
            rotation: a,
            centre: scene.centre(a),
        };
        let want = solve_impact(
            scene.body(),
            pose,
            State {
                velocity: v,
                omega: w,
            },
            &planes,
            law,
            scene.tolerance(),
        )
        .unwrap();
        let scale = v.length() + l * w.length();
        let dv = (DVec3::from_array(got.velocity_after) - want.after.velocity).length();
        let dw = (DVec3::from_array(got.omega_after) - want.after.omega).length() * l;
        let dt = (got.energy_after - want.energy_after).abs() / want.energy_before;
        let err = (dv.max(dw) / scale).max(dt);
        assert!(
            err.is_finite(),
            "sample {}: non-finite result {got:?}",
            got.index
        );
        let kernel_gain = got.status.has(Status::ENERGY_GAIN);
        assert_eq!(
            kernel_gain,
            want.flags.energy_gain,
            "sample {} energy_gain flag ({})",
            got.index,
            law.name()
        );
        worst = worst.max(err);
        recomputed += (got.status.has(Status::RECOMPUTED)) as usize;
    }
    (worst, recomputed)
}

#[test]
fn f64_kernel_matches_reference_to_1e12() {
    for name in SCENES {
        let s = scene(name, "f64");
        for law in LAWS {
            let (worst, _) = worst_error(&s, law, 1_000_000, 4096);
            eprintln!("{name} {} f64: worst {worst:.2e}", law.name());
            assert!(
                worst < 1e-12,
                "{name} {}: f64 kernel error {worst:e}",
                law.name()
            );
        }
    }
}

#[test]
fn f32_kernel_within_documented_bound() {
    for name in SCENES {
        let s = scene(name, "f32");
        for law in LAWS {
            let (worst, recomputed) = worst_error(&s, law, 0, 8192);
            eprintln!(
                "{name} {} f32: worst {worst:.2e}, {recomputed} recomputed in f64",
                law.name()
            );
            assert!(
                worst < F32_VELOCITY_BOUND,
                "{name} {}: f32 kernel error {worst:e}",
                law.name()
            );
        }
    }
}
