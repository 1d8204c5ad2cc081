//! Samples one by one through the lane kernel, for tests and inspection.

use crate::config::{Keep, Scene};
use crate::engine::batch::{block_lanes, fallback, Work};
use crate::engine::with_kernel;
use crate::kernel::Consts;
use crate::kernel::{KernelVariant, Status};
use crate::lanes::dispatch::BLOCK;
use crate::lanes::Real;
use crate::physics::Law;
use crate::sampler::Sampler;

/// One sample as the kernel saw and solved it, in f64.
#[derive(Debug, Clone, PartialEq)]
pub struct SampleOutcome {
    pub index: u64,
    /// Rotation body → world, row-major.
    pub rotation: [f64; 9],
    pub velocity: [f64; 3],
    pub omega: [f64; 3],
    /// Impulse per touching plane (scene order).
    pub impulses: Vec<f64>,
    /// With friction: `|f_i|` (N·s) and `|c⁺_t,i|` (m/s) per touching plane.
    pub tangential: Vec<f64>,
    pub sliding: Vec<f64>,
    /// Normal velocity of the contact point per touching plane, before and
    /// after the impact (m/s).
    pub vn_before: Vec<f64>,
    pub vn_after: Vec<f64>,
    pub velocity_after: [f64; 3],
    pub omega_after: [f64; 3],
    pub energy_before: f64,
    pub energy_after: f64,
    /// Kernel status bits (see `kernel`).
    pub status: Status,
}

fn evaluate_typed<T: Real, const N: usize, const ROT: bool, const CPL: bool, const FR: bool>(
    scene: &Scene,
    law: Law,
    (first, count): (u64, usize),
) -> Vec<SampleOutcome> {
    let consts = Consts::<T, N>::new(scene);
    let sampler = Sampler::new(scene);
    let mut work = Work::<T, N>::new(1);
    let mut out = Vec::with_capacity(count);
    let mut start = first;
    while out.len() < count {
        let n = (count - out.len()).min(BLOCK);
        block_lanes::<T, N, ROT, CPL, FR>(
            &consts,
            &sampler,
            &[law],
            start,
            &mut work.inputs,
            &mut work.geo,
            &mut work.outs,
            &mut work.frame,
            &mut work.sweep,
        );
        fallback(scene, &sampler, &[law], start, &mut work, n, None);
        let o = &work.outs[0];
        let x = &work.inputs;
        for s in 0..n {
            let f = |a: &[[T; BLOCK]; 3]| [a[0][s].to_f64(), a[1][s].to_f64(), a[2][s].to_f64()];
            out.push(SampleOutcome {
                index: start + s as u64,
                rotation: std::array::from_fn(|k| x.a[k][s].to_f64()),
                velocity: f(&x.v),
                omega: f(&x.w),
                impulses: (0..N).map(|i| o.lambda[i][s].to_f64()).collect(),
                tangential: (0..N).map(|i| o.tangential[i][s].to_f64()).collect(),
                sliding: (0..N).map(|i| o.sliding[i][s].to_f64()).collect(),
                vn_before: (0..N).map(|i| work.geo.vn[i][s].to_f64()).collect(),
                vn_after: (0..N).map(|i| o.vn_after[i][s].to_f64()).collect(),
                velocity_after: f(&o.v_after),
                omega_after: f(&o.w_after),
                energy_before: work.geo.t_before[s].to_f64(),
                energy_after: o.t_after[s].to_f64(),
                status: o.status[s],
            });
        }
        start += n as u64;
    }
    out
}

/// Runs samples `first .. first + count` of a scene through the lane kernel
/// (with its f64 fallback) under one law, at the scene's precision. For
/// tests and per-sample inspection; `run` is the fast path.
pub fn evaluate_samples(scene: &Scene, law: Law, first: u64, count: usize) -> Vec<SampleOutcome> {
    evaluate_samples_with(
        scene,
        law,
        first,
        count,
        KernelVariant::of(scene, Keep::NONE),
    )
}

/// [`evaluate_samples`] through a given kernel variant (tests compare the
/// specialised kernels with the one that computes every effect).
pub fn evaluate_samples_with(
    scene: &Scene,
    law: Law,
    first: u64,
    count: usize,
    variant: KernelVariant,
) -> Vec<SampleOutcome> {
    with_kernel!(scene, variant, evaluate_typed(scene, law, (first, count)))
}
