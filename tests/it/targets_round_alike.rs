//! Results do not depend on the machine: the lane code as the run uses it
//! (`sample_block` and `kernel_block`, multiversioned, so AVX-512 or
//! AVX2+FMA where the CPU has them) gives the same bits as the same code
//! compiled into this test for baseline x86-64 (SSE2, no FMA unit, so every
//! `mul_add` runs as a software fma). On a CPU without AVX2 and FMA both
//! sides are baseline code: the tests still run, compare nothing that
//! differs, and say so on stderr ([`compared`]); CI's machines have AVX2.

use crate::support;

use impactmc::engine::{kernel_block, sample_block};
use impactmc::kernel::{geometry, impulses, post, Consts, Geometry, LawOut};
use impactmc::lanes::Real;
use impactmc::physics::Law;
use impactmc::sampler::{Inputs, Sampler};

fn bits<T: Real>(rows: &[[T; impactmc::lanes::dispatch::BLOCK]]) -> Vec<u64> {
    rows.iter()
        .flat_map(|r| r.iter().map(|x| x.to_f64().to_bits()))
        .collect()
}

/// Whether this CPU runs a target other than the baseline (AVX2 and FMA,
/// or AVX-512); if not, says on stderr that `what` compares baseline code
/// with itself here.
fn compared(what: &str) -> bool {
    #[cfg(target_arch = "x86_64")]
    let wide =
        std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma");
    #[cfg(not(target_arch = "x86_64"))]
    let wide = false;
    if !wide {
        eprintln!(
            "targets_round_alike: {what}: this CPU has no AVX2+FMA, so both sides are \
             baseline code and nothing that differs is compared"
        );
    }
    wide
}

fn same_bits<T: Real, const N: usize, const ROT: bool, const CPL: bool>(name: &str, law: Law) {
    compared(name);
    let s = support::shipped_scene(name, T::NAME);
    let consts = Consts::<T, N>::new(&s);
    let sampler = Sampler::new(&s);
    for first in [0u64, 192 * 1000 + 7, 1 << 40] {
        let mut fast = Inputs::<T>::new();
        sample_block(&sampler, first, &mut fast);
        let mut base = Inputs::<T>::new();
        sampler.fill(first, &mut base);
        assert_eq!(
            bits(&fast.a),
            bits(&base.a),
            "{name} {}: orientations",
            T::NAME
        );
        assert_eq!(
            bits(&fast.v),
            bits(&base.v),
            "{name} {}: velocities",
            T::NAME
        );
        assert_eq!(bits(&fast.w), bits(&base.w), "{name} {}: spins", T::NAME);

        let (mut g1, mut o1) = (Geometry::<T, N>::new(), LawOut::<T, N>::new());
        kernel_block::<T, N, ROT, CPL>(&consts, law, &fast, &mut g1, &mut o1);
        let (mut g2, mut o2) = (Geometry::<T, N>::new(), LawOut::<T, N>::new());
        geometry::<T, N, ROT>(&consts, &fast, &mut g2, true);
        impulses::<T, N, ROT, CPL>(&consts, law, &g2, &mut o2);
        post::<T, N, ROT>(&consts, &fast, &g2, &mut o2);
        let what = format!("{name} {} {law:?}", T::NAME);
        assert_eq!(bits(&g1.vn), bits(&g2.vn), "{what}: v_n");
        assert_eq!(bits(&[g1.t_before]), bits(&[g2.t_before]), "{what}: T⁻");
        assert_eq!(bits(&o1.lambda), bits(&o2.lambda), "{what}: impulses");
        assert_eq!(bits(&o1.v_after), bits(&o2.v_after), "{what}: v⁺");
        assert_eq!(bits(&o1.w_after), bits(&o2.w_after), "{what}: ω⁺");
        assert_eq!(bits(&[o1.t_after]), bits(&[o2.t_after]), "{what}: T⁺");
        assert_eq!(o1.status, o2.status, "{what}: status");
    }
}

#[test]
fn one_plane_in_both_precisions() {
    same_bits::<f32, 1, true, false>("floor", Law::Newton);
    same_bits::<f64, 1, true, false>("floor", Law::Newton);
}

#[test]
fn three_planes_under_every_law_in_both_precisions() {
    for law in [
        Law::Newton,
        Law::Paper,
        Law::Poisson,
        Law::Pgs { sweeps: 8 },
    ] {
        same_bits::<f32, 3, true, true>("corner3", law);
        same_bits::<f64, 3, true, true>("corner3", law);
    }
}

/// RQMC draws: the multiversioned block sampler gives the baseline
/// build's bits, in both precisions (the same block starts, across the
/// points' lookup runs and replicates).
#[test]
fn rqmc_draws_in_both_precisions() {
    compared("rqmc draws");
    fn same_draws<T: Real>() {
        let s = impactmc::config::load_scene(
            &support::repo("configs/corner3.toml"),
            &impactmc::config::Overrides {
                sampling: Some("rqmc".into()),
                precision: Some(T::NAME.parse().unwrap()),
                ..Default::default()
            },
        )
        .unwrap();
        let sampler = Sampler::new(&s);
        for first in [0u64, 192 * 1000 + 7, (5 << 20) + 200, 1 << 40] {
            let mut fast = Inputs::<T>::new();
            sample_block(&sampler, first, &mut fast);
            let mut base = Inputs::<T>::new();
            sampler.fill(first, &mut base);
            for (what, a, b) in [
                ("orientations", bits(&fast.a), bits(&base.a)),
                ("velocities", bits(&fast.v), bits(&base.v)),
                ("spins", bits(&fast.w), bits(&base.w)),
            ] {
                assert_eq!(a, b, "{} rqmc {what} at {first}", T::NAME);
            }
        }
    }
    same_draws::<f32>();
    same_draws::<f64>();
}
