//! The Monte Carlo run: batches of samples in parallel (rayon), each batch a
//! sequence of SoA blocks through sampler → kernel → accumulators; batch
//! results are merged along a fixed tree over batch indices ([`Node`]), so
//! the answer depends neither on the thread count and scheduling nor on how
//! the batches are split into shards.

// Lane code indexes SoA arrays by lane and contact on purpose: the index
// form is what the loop vectoriser sees through.
#![allow(clippy::needless_range_loop, clippy::manual_memcpy)]

use std::time::Instant;

use glam::{DMat3, DQuat};
use multiversion::multiversion;
use rayon::prelude::*;

use crate::kernel::{
    check_extra_planes, geometry, impulses, post, recompute, Consts, Geometry, LawOut,
    ACTIVE_SHIFT, DEGENERATE, ENERGY_GAIN, JAMMED, PENETRATING, RECOMPUTED, UNSOLVED,
};
use crate::lanes::{select, Real};
use crate::physics::Law;
use crate::sampler::{Inputs, Sampler, ALL_ROWS, BLOCK};
use crate::scene::{Precision, Scene};
use crate::stats::{scatter, LogHistogram, Moments, Stat, BINS};

/// The kernel instantiation a run uses, chosen once per run from the scene's
/// derived effects: each effect a scene does not need is compiled out of
/// its kernel (const generics), not branched over per sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct KernelVariant {
    /// Lever arms, per-lane G and ω⁺ (off for spheres).
    pub rotational_coupling: bool,
    /// The LCP over the touching planes (off for one plane, or G diagonal
    /// by geometry: every law is then the per-contact closed form).
    pub coupled_contacts: bool,
}

/// Effects to keep computing although the scene does not need them (same
/// answers, more work): for measuring what compiling an effect out saves.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Keep {
    /// Lever arms, per-lane G, ω⁺ and the orientation draws.
    pub rotation: bool,
    /// The LCP over the touching planes.
    pub lcp: bool,
    /// Every statistic: all quantiles and the per-set groups.
    pub statistics: bool,
}

impl Keep {
    pub const NONE: Self = Self {
        rotation: false,
        lcp: false,
        statistics: false,
    };
    pub const ALL: Self = Self {
        rotation: true,
        lcp: true,
        statistics: true,
    };

    /// Parses `rotation`, `lcp`, `statistics` or `all`.
    pub fn with(mut self, name: &str) -> Result<Self, String> {
        match name {
            "rotation" => self.rotation = true,
            "lcp" => self.lcp = true,
            "statistics" => self.statistics = true,
            "all" => self = Self::ALL,
            other => {
                return Err(format!(
                    "--keep: unknown effect {other:?} (expected rotation, lcp, statistics or all)"
                ))
            }
        }
        Ok(self)
    }
}

impl KernelVariant {
    /// The scene's variant, with the effects in `keep` compiled in whatever
    /// the scene needs.
    pub fn of(scene: &Scene, keep: Keep) -> Self {
        let e = scene.effects();
        Self {
            rotational_coupling: keep.rotation || e.rotational_coupling,
            coupled_contacts: keep.lcp || e.coupled_contacts,
        }
    }

    /// `rotation+lcp`, `rotation`, `lcp` or `closed-form`.
    pub fn name(&self) -> &'static str {
        match (self.rotational_coupling, self.coupled_contacts) {
            (true, true) => "rotation+lcp",
            (true, false) => "rotation",
            (false, true) => "lcp",
            (false, false) => "closed-form",
        }
    }
}

/// Calls `f::<T, N, ROT, CPL>(args)` for a scene's precision, contact count
/// and kernel variant.
macro_rules! with_kernel {
    ($scene:expr, $variant:expr, $f:ident($($arg:expr),*)) => {{
        let v: KernelVariant = $variant;
        macro_rules! by_variant {
            ($t:ty, $n:literal) => {
                match (v.rotational_coupling, v.coupled_contacts) {
                    (true, true) => $f::<$t, $n, true, true>($($arg),*),
                    (true, false) => $f::<$t, $n, true, false>($($arg),*),
                    (false, true) => $f::<$t, $n, false, true>($($arg),*),
                    (false, false) => $f::<$t, $n, false, false>($($arg),*),
                }
            };
        }
        match ($scene.precision(), $scene.touching().len()) {
            (Precision::F32, 1) => by_variant!(f32, 1),
            (Precision::F32, 2) => by_variant!(f32, 2),
            (Precision::F32, _) => by_variant!(f32, 3),
            (Precision::F64, 1) => by_variant!(f64, 1),
            (Precision::F64, 2) => by_variant!(f64, 2),
            (Precision::F64, _) => by_variant!(f64, 3),
        }
    }};
}

/// Statistics of the samples in one active-contact set.
#[derive(Debug, Clone, Default)]
pub struct GroupAcc {
    pub samples: u64,
    pub impacts: u64,
    pub energy_ratio: Stat,
    pub omega_after_norm: Stat,
    pub velocity_after_norm: Stat,
}

/// Everything accumulated for one law.
#[derive(Debug, Clone)]
pub struct LawAcc {
    pub samples: u64,
    pub impacts: u64,
    pub energy_gain: u64,
    pub degenerate: u64,
    pub jammed: u64,
    pub unsolved: u64,
    pub recomputed: u64,
    pub penetrating: u64,
    /// Counts per active set (bit i: touching plane i took λ > 0), all samples.
    pub active_sets: Vec<u64>,
    /// Over impacting samples. Their histograms are filled per contact set
    /// (each impacting sample is in exactly one) and summed into these by
    /// [`RunAcc::finish`].
    pub energy_ratio: Stat,
    pub omega_after_norm: Stat,
    pub velocity_after_norm: Stat,
    /// Per touching plane, over impacting samples (zeros included).
    pub impulse: Vec<Stat>,
    /// Per touching plane, `−v_n⁺/v_n⁻` over samples where it approached.
    pub rebound: Vec<Stat>,
    /// Per active set: moments of the three post-impact statistics.
    pub groups: Vec<GroupAcc>,
}

/// Paired differences `law − laws[0]` on the same impacting samples.
#[derive(Debug, Clone, Default)]
pub struct PairAcc {
    pub energy_ratio: Moments,
    pub omega_after_norm: Moments,
    pub velocity_after_norm: Moments,
}

#[derive(Debug, Clone)]
pub struct RunAcc {
    pub laws: Vec<LawAcc>,
    /// `pairs[i]` is laws[i + 1] − laws[0].
    pub pairs: Vec<PairAcc>,
}

impl LawAcc {
    fn new(contacts: usize) -> Self {
        Self {
            samples: 0,
            impacts: 0,
            energy_gain: 0,
            degenerate: 0,
            jammed: 0,
            unsolved: 0,
            recomputed: 0,
            penetrating: 0,
            active_sets: vec![0; 1 << contacts],
            energy_ratio: Stat::default(),
            omega_after_norm: Stat::default(),
            velocity_after_norm: Stat::default(),
            impulse: vec![Stat::default(); contacts],
            rebound: vec![Stat::default(); contacts],
            groups: vec![GroupAcc::default(); 1 << contacts],
        }
    }

    fn flush(&mut self) {
        for s in [
            &mut self.energy_ratio,
            &mut self.omega_after_norm,
            &mut self.velocity_after_norm,
        ] {
            s.flush();
        }
        for s in &mut self.impulse {
            s.flush();
        }
        for m in &mut self.rebound {
            m.flush();
        }
        for g in &mut self.groups {
            g.energy_ratio.flush();
            g.omega_after_norm.flush();
            g.velocity_after_norm.flush();
        }
    }

    /// Back to the state of `new`, keeping the histograms' tables (the
    /// engine tests check every field through [`RunAcc::visit`]).
    fn clear(&mut self) {
        for c in [
            &mut self.samples,
            &mut self.impacts,
            &mut self.energy_gain,
            &mut self.degenerate,
            &mut self.jammed,
            &mut self.unsolved,
            &mut self.recomputed,
            &mut self.penetrating,
        ] {
            *c = 0;
        }
        self.active_sets.fill(0);
        let headline = [
            &mut self.energy_ratio,
            &mut self.omega_after_norm,
            &mut self.velocity_after_norm,
        ];
        for s in headline
            .into_iter()
            .chain(&mut self.impulse)
            .chain(&mut self.rebound)
        {
            s.clear();
        }
        for g in &mut self.groups {
            (g.samples, g.impacts) = (0, 0);
            g.energy_ratio.clear();
            g.omega_after_norm.clear();
            g.velocity_after_norm.clear();
        }
    }

    fn merge(&mut self, o: &LawAcc) {
        self.samples += o.samples;
        self.impacts += o.impacts;
        self.energy_gain += o.energy_gain;
        self.degenerate += o.degenerate;
        self.jammed += o.jammed;
        self.unsolved += o.unsolved;
        self.recomputed += o.recomputed;
        self.penetrating += o.penetrating;
        for (a, b) in self.active_sets.iter_mut().zip(&o.active_sets) {
            *a += b;
        }
        self.energy_ratio.merge(&o.energy_ratio);
        self.omega_after_norm.merge(&o.omega_after_norm);
        self.velocity_after_norm.merge(&o.velocity_after_norm);
        for (a, b) in self.impulse.iter_mut().zip(&o.impulse) {
            a.merge(b);
        }
        for (a, b) in self.rebound.iter_mut().zip(&o.rebound) {
            a.merge(b);
        }
        for (a, b) in self.groups.iter_mut().zip(&o.groups) {
            a.samples += b.samples;
            a.impacts += b.impacts;
            a.energy_ratio.merge(&b.energy_ratio);
            a.omega_after_norm.merge(&b.omega_after_norm);
            a.velocity_after_norm.merge(&b.velocity_after_norm);
        }
    }
}

impl RunAcc {
    pub fn new(laws: usize, contacts: usize) -> Self {
        Self {
            laws: (0..laws).map(|_| LawAcc::new(contacts)).collect(),
            pairs: vec![PairAcc::default(); laws.saturating_sub(1)],
        }
    }

    /// Back to the state of [`Self::new`], keeping the histograms' tables,
    /// so that a run reuses its batch accumulators instead of allocating
    /// (and page-faulting in) fresh ones per batch.
    pub fn clear(&mut self) {
        for l in &mut self.laws {
            l.clear();
        }
        self.pairs.fill(PairAcc::default());
    }

    pub fn flush(&mut self) {
        for l in &mut self.laws {
            l.flush();
        }
        for p in &mut self.pairs {
            p.energy_ratio.flush();
            p.omega_after_norm.flush();
            p.velocity_after_norm.flush();
        }
    }

    /// Completes a run's accumulators: the "all" histograms are the sums of
    /// the contact sets' (in set order).
    pub fn finish(&mut self) {
        for l in &mut self.laws {
            for g in &l.groups {
                l.energy_ratio.hist.merge(&g.energy_ratio.hist);
                l.omega_after_norm.hist.merge(&g.omega_after_norm.hist);
                l.velocity_after_norm
                    .hist
                    .merge(&g.velocity_after_norm.hist);
            }
        }
    }

    /// Merges `o` after `self`; merging in a fixed order gives bit-identical
    /// results.
    pub fn merge(&mut self, o: &RunAcc) {
        for (a, b) in self.laws.iter_mut().zip(&o.laws) {
            a.merge(b);
        }
        for (a, b) in self.pairs.iter_mut().zip(&o.pairs) {
            a.energy_ratio.merge(&b.energy_ratio);
            a.omega_after_norm.merge(&b.omega_after_norm);
            a.velocity_after_norm.merge(&b.velocity_after_norm);
        }
    }
}

/// One accumulator field, as [`RunAcc::visit`] hands it out.
pub enum Slot<'a> {
    Count(&'a mut u64),
    Moments(&'a mut Moments),
    Histogram(&'a mut LogHistogram),
}

impl RunAcc {
    /// Every field with a stable path (`law0.groups.3.energy_ratio.hist`),
    /// in a fixed order: how shard files store and restore accumulators.
    pub fn visit(&mut self, f: &mut dyn FnMut(&str, Slot)) {
        fn stat(f: &mut dyn FnMut(&str, Slot), path: &str, s: &mut Stat) {
            f(&format!("{path}.moments"), Slot::Moments(&mut s.moments));
            f(&format!("{path}.hist"), Slot::Histogram(&mut s.hist));
        }
        for (li, l) in self.laws.iter_mut().enumerate() {
            let p = format!("law{li}");
            for (name, c) in [
                ("samples", &mut l.samples),
                ("impacts", &mut l.impacts),
                ("energy_gain", &mut l.energy_gain),
                ("degenerate", &mut l.degenerate),
                ("jammed", &mut l.jammed),
                ("unsolved", &mut l.unsolved),
                ("recomputed", &mut l.recomputed),
                ("penetrating", &mut l.penetrating),
            ] {
                f(&format!("{p}.{name}"), Slot::Count(c));
            }
            for (m, c) in l.active_sets.iter_mut().enumerate() {
                f(&format!("{p}.active_sets.{m}"), Slot::Count(c));
            }
            stat(f, &format!("{p}.energy_ratio"), &mut l.energy_ratio);
            stat(f, &format!("{p}.omega_after_norm"), &mut l.omega_after_norm);
            stat(
                f,
                &format!("{p}.velocity_after_norm"),
                &mut l.velocity_after_norm,
            );
            for (i, s) in l.impulse.iter_mut().enumerate() {
                stat(f, &format!("{p}.impulse.{i}"), s);
            }
            for (i, s) in l.rebound.iter_mut().enumerate() {
                stat(f, &format!("{p}.rebound.{i}"), s);
            }
            for (m, g) in l.groups.iter_mut().enumerate() {
                let q = format!("{p}.groups.{m}");
                f(&format!("{q}.samples"), Slot::Count(&mut g.samples));
                f(&format!("{q}.impacts"), Slot::Count(&mut g.impacts));
                stat(f, &format!("{q}.energy_ratio"), &mut g.energy_ratio);
                stat(f, &format!("{q}.omega_after_norm"), &mut g.omega_after_norm);
                stat(
                    f,
                    &format!("{q}.velocity_after_norm"),
                    &mut g.velocity_after_norm,
                );
            }
        }
        for (pi, pa) in self.pairs.iter_mut().enumerate() {
            let p = format!("pair{}", pi + 1);
            f(
                &format!("{p}.energy_ratio"),
                Slot::Moments(&mut pa.energy_ratio),
            );
            f(
                &format!("{p}.omega_after_norm"),
                Slot::Moments(&mut pa.omega_after_norm),
            );
            f(
                &format!("{p}.velocity_after_norm"),
                Slot::Moments(&mut pa.velocity_after_norm),
            );
        }
    }
}

/// Per-lane statistics of one law in a block, in the kernel's precision,
/// with their masks (weights 1 or 0, in the same type). Cache-line aligned.
#[repr(C, align(64))]
struct Derived<T, const N: usize> {
    ratio: [T; BLOCK],
    omega: [T; BLOCK],
    speed: [T; BLOCK],
    /// Weights (1 or 0) of impacting lanes; values are finite everywhere.
    impacting: [T; BLOCK],
    lambda: [[T; BLOCK]; N],
    rebound: [[T; BLOCK]; N],
    approaching: [[T; BLOCK]; N],
    active: [u32; BLOCK],
    mask: [T; BLOCK],
}

impl<T: Real, const N: usize> Derived<T, N> {
    fn new() -> Box<Self> {
        Box::new(Self {
            ratio: [T::ZERO; BLOCK],
            omega: [T::ZERO; BLOCK],
            speed: [T::ZERO; BLOCK],
            impacting: [T::ZERO; BLOCK],
            lambda: [[T::ZERO; BLOCK]; N],
            rebound: [[T::ZERO; BLOCK]; N],
            approaching: [[T::ZERO; BLOCK]; N],
            active: [0; BLOCK],
            mask: [T::ZERO; BLOCK],
        })
    }
}

/// Scratch space of one worker: allocated once per batch, reused by blocks.
struct Work<T, const N: usize> {
    inputs: Box<Inputs<T>>,
    geo: Box<Geometry<T, N>>,
    outs: Vec<Box<LawOut<T, N>>>,
    derived: Box<Derived<T, N>>,
    /// laws[0]'s per-lane statistics, for paired differences.
    first: Box<Derived<T, N>>,
    diff: Box<[T; BLOCK]>,
}

impl<T: Real, const N: usize> Work<T, N> {
    fn new(laws: usize) -> Self {
        Self {
            inputs: Inputs::new(),
            geo: Geometry::new(),
            outs: (0..laws).map(|_| LawOut::new()).collect(),
            derived: Derived::new(),
            first: Derived::new(),
            diff: Box::new([T::ZERO; BLOCK]),
        }
    }
}

/// What the statistics pass computes: the scene's requested statistics
/// (its derived effect set), or everything under `--all-effects`. Chosen
/// once per run; each choice skips whole passes over a block, never a lane.
#[derive(Debug, Clone, Copy)]
struct StatsPlan {
    /// Histograms of energy_ratio, |ω⁺|, |v⁺|, impulse, rebound.
    quantiles: [bool; 5],
    by_set: bool,
    /// |ω⁺| when it is the same in every sample: counted, not computed.
    constant_spin: Option<f64>,
}

impl StatsPlan {
    fn of(scene: &Scene, keep: Keep) -> Self {
        let e = scene.effects();
        let st = if keep.statistics {
            crate::scene::Statistics::ALL
        } else {
            e.statistics
        };
        Self {
            quantiles: st.quantiles,
            by_set: st.by_active_set,
            // With rotation kept, |ω⁺| is computed per sample.
            constant_spin: if keep.rotation { None } else { e.constant_spin },
        }
    }
}

/// Per-lane statistics of a law's block results. Lanes past `count` and
/// penetrating lanes get weight 0, and every value is made finite (0 where
/// its weight is 0), so masked sums are plain arithmetic. Everything stays
/// in the kernel's precision (the values are no more accurate than that);
/// the accumulators combine blocks in f64.
///
/// Returns the block's counts, taken in the same pass over the statuses.
#[inline(always)]
fn derive<T: Real, const N: usize>(
    geo: &Geometry<T, N>,
    out: &LawOut<T, N>,
    count: usize,
    plan: StatsPlan,
    d: &mut Derived<T, N>,
) -> BlockCounts {
    let approach_mask = (1u32 << N) - 1;
    let w01 = |c: bool| select(c, T::ONE, T::ZERO);
    let mut n = BlockCounts::default();
    // |ω⁺| per lane, unless it is the same in every sample.
    let omega_per_lane = plan.constant_spin.is_none();
    // One loop with non-short-circuit logic, so that it vectorises: the
    // divisions and square roots overlap the rest (in separate loops each
    // waited on the divider: S1 about 2 % slower). Counts are
    // compare-and-sum reductions in lanes (a scatter into one counter per
    // set would chain every sample through memory).
    const { assert!(BLOCK < 256) };
    for s in 0..BLOCK {
        let st = out.status[s];
        let in_batch = s < count;
        let valid = in_batch & (st & PENETRATING == 0);
        let approaching = st & approach_mask;
        let impacting = valid & (approaching != 0);
        let active = (st >> ACTIVE_SHIFT) & approach_mask;
        d.impacting[s] = w01(impacting);
        d.active[s] = active;
        for k in 0..BlockCounts::FLAGS.len() {
            n.flags[k] += (in_batch & (st & BlockCounts::FLAGS[k] != 0)) as u32;
        }
        n.impacts += impacting as u32;
        // Samples per active set: each valid lane adds 1 to its set's byte
        // of a 64-bit word (fewer than 256 lanes per block, so no byte
        // carries into the next, whatever the partial sums).
        n.per_set += (valid as u64) << (8 * (active & 7));
        let ratio = out.t_after[s] / geo.t_before[s];
        d.ratio[s] = select(impacting, ratio, T::ZERO);
        if omega_per_lane {
            let (a, b, c) = (out.w_after[0][s], out.w_after[1][s], out.w_after[2][s]);
            let w = (a * a + b * b + c * c).sqrt();
            d.omega[s] = select(impacting, w, T::ZERO);
        }
        let (a, b, c) = (out.v_after[0][s], out.v_after[1][s], out.v_after[2][s]);
        let v = (a * a + b * b + c * c).sqrt();
        d.speed[s] = select(impacting, v, T::ZERO);
        for i in 0..N {
            let toward = valid & (approaching & (1 << i) != 0);
            d.approaching[i][s] = w01(toward);
            d.lambda[i][s] = select(impacting, out.lambda[i][s], T::ZERO);
            let r = -out.vn_after[i][s] / geo.vn[i][s];
            d.rebound[i][s] = select(toward, r, T::ZERO);
        }
    }
    n
}

/// A law's counts over one block (from [`derive`]).
#[derive(Debug, Clone, Copy, Default)]
struct BlockCounts {
    /// Samples of the batch with each of [`Self::FLAGS`].
    flags: [u32; 6],
    /// Samples with at least one approaching contact (and not penetrating).
    impacts: u32,
    /// Valid samples per active set: set m's count in byte m.
    per_set: u64,
}

impl BlockCounts {
    const FLAGS: [u32; 6] = [
        ENERGY_GAIN,
        DEGENERATE,
        JAMMED,
        UNSOLVED,
        RECOMPUTED,
        PENETRATING,
    ];
}

/// The vectorised part of a block: draws, geometry, impulses and post
/// quantities for every law. Compiled for AVX-512, AVX2+FMA and the
/// baseline; the best the CPU has is chosen at run time.
#[multiversion(targets(
    "x86_64+avx512f+avx512bw+avx512cd+avx512dq+avx512vl+avx2+fma",
    "x86_64+avx2+fma",
))]
fn block_lanes<T: Real, const N: usize, const ROT: bool, const CPL: bool>(
    consts: &Consts<T, N>,
    sampler: &Sampler,
    laws: &[Law],
    first: u64,
    inputs: &mut Inputs<T>,
    geo: &mut Geometry<T, N>,
    outs: &mut [Box<LawOut<T, N>>],
) {
    crate::lanes::align_frame();
    sampler.fill(first, inputs);
    let newton_only = CPL && laws.iter().all(|l| matches!(l, Law::Newton));
    geometry::<T, N, ROT>(consts, inputs, geo, !newton_only);
    for (law, out) in laws.iter().zip(outs.iter_mut()) {
        impulses::<T, N, ROT, CPL>(consts, *law, geo, out);
        post::<T, N, ROT>(consts, inputs, geo, out);
    }
}

/// Per-sample rows of one batch, column-major, in sample order (the columns
/// of [`sample_columns`]).
#[derive(Debug, Clone, Default)]
pub struct SampleRows {
    pub index: Vec<u64>,
    pub floats: Vec<Vec<f64>>,
    pub ints: Vec<Vec<u32>>,
}

impl SampleRows {
    fn new(floats: usize, ints: usize) -> Self {
        Self {
            index: Vec::new(),
            floats: vec![Vec::new(); floats],
            ints: vec![Vec::new(); ints],
        }
    }

    pub fn len(&self) -> usize {
        self.index.len()
    }

    pub fn is_empty(&self) -> bool {
        self.index.is_empty()
    }

    /// Appends `other`'s rows.
    pub fn append(&mut self, other: &SampleRows) {
        self.index.extend_from_slice(&other.index);
        for (a, b) in self.floats.iter_mut().zip(&other.floats) {
            a.extend_from_slice(b);
        }
        for (a, b) in self.ints.iter_mut().zip(&other.ints) {
            a.extend_from_slice(b);
        }
    }
}

/// Names of the per-sample columns after `sample` (u64): the f64 columns,
/// then the u32 columns. Units: m/s, rad/s, J, N·s; `active_LAW` is the
/// active-set bitmask over the touching planes in scene order, `flags_LAW`
/// the kernel status bits (see README).
pub fn sample_columns(scene: &Scene) -> (Vec<String>, Vec<String>) {
    let planes: Vec<&str> = scene
        .touching()
        .iter()
        .map(|&i| scene.planes()[i].name.as_str())
        .collect();
    let mut f: Vec<String> = [
        "q_w",
        "q_x",
        "q_y",
        "q_z",
        "v_x",
        "v_y",
        "v_z",
        "omega_x",
        "omega_y",
        "omega_z",
        "energy_before",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    f.extend(planes.iter().map(|p| format!("vn_before_{p}")));
    let mut ints = Vec::new();
    for law in scene.laws() {
        let l = law.name();
        f.push(format!("energy_after_{l}"));
        f.push(format!("energy_ratio_{l}"));
        for c in ["x", "y", "z"] {
            f.push(format!("v_after_{c}_{l}"));
        }
        for c in ["x", "y", "z"] {
            f.push(format!("omega_after_{c}_{l}"));
        }
        f.extend(planes.iter().map(|p| format!("impulse_{l}_{p}")));
        f.extend(planes.iter().map(|p| format!("vn_after_{l}_{p}")));
        ints.push(format!("active_{l}"));
        ints.push(format!("flags_{l}"));
    }
    (f, ints)
}

/// Appends a block's rows (after recomputation) in the order of
/// [`sample_columns`].
fn push_rows<T: Real, const N: usize>(
    work: &Work<T, N>,
    first: u64,
    count: usize,
    rows: &mut SampleRows,
) {
    let x = &work.inputs;
    for s in 0..count {
        rows.index.push(first + s as u64);
        let a = DMat3::from_cols_array(&std::array::from_fn(|k| x.a[k][s].to_f64())).transpose();
        let q = DQuat::from_mat3(&a);
        let q = if q.w < 0.0 { -q } else { q };
        let mut f = rows.floats.iter_mut();
        let mut put = |v: f64| f.next().expect("column count").push(v);
        for v in [q.w, q.x, q.y, q.z] {
            put(v);
        }
        for k in 0..3 {
            put(x.v[k][s].to_f64());
        }
        for k in 0..3 {
            put(x.w[k][s].to_f64());
        }
        let t0 = work.geo.t_before[s].to_f64();
        put(t0);
        for i in 0..N {
            put(work.geo.vn[i][s].to_f64());
        }
        for out in &work.outs {
            let t1 = out.t_after[s].to_f64();
            put(t1);
            put(t1 / t0);
            for k in 0..3 {
                put(out.v_after[k][s].to_f64());
            }
            for k in 0..3 {
                put(out.w_after[k][s].to_f64());
            }
            for i in 0..N {
                put(out.lambda[i][s].to_f64());
            }
            for i in 0..N {
                put(out.vn_after[i][s].to_f64());
            }
        }
        let mut ints = rows.ints.iter_mut();
        for out in &work.outs {
            let st = out.status[s];
            ints.next()
                .expect("column count")
                .push((st >> ACTIVE_SHIFT) & ((1 << N) - 1));
            ints.next().expect("column count").push(st);
        }
    }
}

/// The contact kernel alone on a block of given inputs (geometry, one law's
/// impulses, post-impact quantities), with the same run-time dispatch as a
/// run. For benchmarks that compare kernel designs on identical inputs.
#[multiversion(targets(
    "x86_64+avx512f+avx512bw+avx512cd+avx512dq+avx512vl+avx2+fma",
    "x86_64+avx2+fma",
))]
pub fn kernel_block<T: Real, const N: usize, const ROT: bool, const CPL: bool>(
    consts: &Consts<T, N>,
    law: Law,
    inputs: &Inputs<T>,
    geo: &mut Geometry<T, N>,
    out: &mut LawOut<T, N>,
) {
    crate::lanes::align_frame();
    geometry::<T, N, ROT>(consts, inputs, geo, !(CPL && matches!(law, Law::Newton)));
    impulses::<T, N, ROT, CPL>(consts, law, geo, out);
    post::<T, N, ROT>(consts, inputs, geo, out);
}

/// The sampler alone on one block, with the same run-time dispatch as a
/// run. For benchmarks of the draws.
#[multiversion(targets(
    "x86_64+avx512f+avx512bw+avx512cd+avx512dq+avx512vl+avx2+fma",
    "x86_64+avx2+fma",
))]
pub fn sample_block<T: Real>(sampler: &Sampler, first: u64, inputs: &mut Inputs<T>) {
    crate::lanes::align_frame();
    sampler.fill(first, inputs);
}

/// One block: the lane passes, then the reference for flagged lanes, then the
/// accumulators (scalar).
/// What every block of a run shares.
struct Ctx<'a, T, const N: usize> {
    scene: &'a Scene,
    consts: &'a Consts<T, N>,
    sampler: &'a Sampler,
    plan: StatsPlan,
}

fn run_block<T: Real, const N: usize, const ROT: bool, const CPL: bool>(
    ctx: &Ctx<T, N>,
    first: u64,
    count: usize,
    work: &mut Work<T, N>,
    acc: &mut RunAcc,
    rows: Option<&mut SampleRows>,
) {
    let Ctx {
        scene,
        consts,
        sampler,
        ..
    } = *ctx;
    let laws = scene.laws();
    block_lanes::<T, N, ROT, CPL>(
        consts,
        sampler,
        laws,
        first,
        &mut work.inputs,
        &mut work.geo,
        &mut work.outs,
    );
    fallback(scene, sampler, laws, first, work, count);
    block_stats(
        &work.geo,
        &work.outs,
        count,
        ctx.plan,
        &mut work.derived,
        &mut work.first,
        &mut work.diff,
        acc,
    );
    if let Some(rows) = rows {
        push_rows(work, first, count, rows);
    }
}

/// The scalar part after the lane passes, for every law of a block: planes
/// outside the placement are checked (only in scenes that have them), and
/// flagged lanes are solved again by the f64 reference.
fn fallback<T: Real, const N: usize>(
    scene: &Scene,
    sampler: &Sampler,
    laws: &[Law],
    first: u64,
    work: &mut Work<T, N>,
    count: usize,
) {
    let extra_planes = scene.planes().len() > N;
    if extra_planes {
        check_extra_planes(scene, &work.inputs, &mut work.geo, count);
    }
    if sampler.partial_rows() {
        // The reference reads the whole orientation of a flagged lane: its
        // unwritten rows, as the full fill would have written them.
        let mut flagged = 0u32;
        for out in work.outs.iter() {
            for st in &out.status[..count] {
                flagged |= st & crate::kernel::RECOMPUTE;
            }
        }
        if flagged != 0 {
            for s in 0..count {
                if work
                    .outs
                    .iter()
                    .any(|o| o.status[s] & crate::kernel::RECOMPUTE != 0)
                {
                    let a = sampler.orientation_of::<T>(first + s as u64);
                    for (k, ak) in a.into_iter().enumerate() {
                        work.inputs.a[k][s] = ak;
                    }
                }
            }
        }
    }
    for (law, out) in laws.iter().zip(work.outs.iter_mut()) {
        if extra_planes {
            // Extra-plane checks landed in geo.status after the lane passes.
            for s in 0..count {
                out.status[s] |= work.geo.status[s] & crate::kernel::RECOMPUTE;
            }
        }
        recompute(scene, *law, &work.inputs, out, count);
    }
}

/// Headline statistic `k` (0 energy ratio, 1 |ω⁺|, 2 |v⁺|) of a contact set.
#[inline(always)]
fn group_stat(g: &mut GroupAcc, k: usize) -> &mut Stat {
    match k {
        0 => &mut g.energy_ratio,
        1 => &mut g.omega_after_norm,
        _ => &mut g.velocity_after_norm,
    }
}

/// Accumulates every law's block results: counters, then moments and
/// histograms as masked vector passes, for the statistics the plan asks
/// for. Compiled like `block_lanes`.
#[multiversion(targets(
    "x86_64+avx512f+avx512bw+avx512cd+avx512dq+avx512vl+avx2+fma",
    "x86_64+avx2+fma",
))]
#[allow(clippy::too_many_arguments)]
fn block_stats<T: Real, const N: usize>(
    geo: &Geometry<T, N>,
    outs: &[Box<LawOut<T, N>>],
    count: usize,
    plan: StatsPlan,
    derived: &mut Box<Derived<T, N>>,
    first: &mut Box<Derived<T, N>>,
    diff: &mut [T; BLOCK],
    acc: &mut RunAcc,
) {
    let mut bins = [0u16; BLOCK];
    let spin = plan.constant_spin;
    for li in 0..outs.len() {
        let la = &mut acc.laws[li];
        let out = &outs[li];
        let n = derive(geo, out, count, plan, derived);
        let d = &mut **derived;
        let c = n.flags;
        la.samples += count as u64;
        la.energy_gain += c[0] as u64;
        la.degenerate += c[1] as u64;
        la.jammed += c[2] as u64;
        la.unsolved += c[3] as u64;
        la.recomputed += c[4] as u64;
        la.penetrating += c[5] as u64;
        let impacts = n.impacts;
        la.impacts += impacts as u64;
        for m in 0..la.active_sets.len() {
            let c = (n.per_set >> (8 * m)) & 0xff;
            la.active_sets[m] += c;
            la.groups[m].samples += c;
        }
        // Moments of the statistics weighted by `impacting`, fused into
        // passes of up to three statistics.
        match spin {
            Some(w) => {
                la.omega_after_norm.moments.push_repeated(w, impacts as u64);
                Moments::push_weighted_many(
                    [
                        &mut la.energy_ratio.moments,
                        &mut la.velocity_after_norm.moments,
                    ],
                    [&d.ratio, &d.speed],
                    &d.impacting,
                );
            }
            None => Moments::push_weighted_many(
                [
                    &mut la.energy_ratio.moments,
                    &mut la.omega_after_norm.moments,
                    &mut la.velocity_after_norm.moments,
                ],
                [&d.ratio, &d.omega, &d.speed],
                &d.impacting,
            ),
        }
        {
            let mut impulse = la.impulse.iter_mut().map(|s| &mut s.moments);
            let ms: [&mut Moments; N] = std::array::from_fn(|_| impulse.next().expect("N"));
            Moments::push_weighted_many(ms, std::array::from_fn(|i| &d.lambda[i]), &d.impacting);
        }
        for i in 0..N {
            if plan.quantiles[3] {
                la.impulse[i].hist.push_weighted(&d.lambda[i], &d.impacting);
            }
            if plan.quantiles[4] {
                la.rebound[i].push_weighted(&d.rebound[i], &d.approaching[i]);
            } else {
                la.rebound[i]
                    .moments
                    .push_weighted(&d.rebound[i], &d.approaching[i]);
            }
        }
        if plan.by_set {
            block_stats_by_set(la, d, count, plan, &mut bins);
        } else {
            // Histograms straight into the "all" statistics.
            if let Some(w) = spin.filter(|_| plan.quantiles[1]) {
                la.omega_after_norm.hist.push_repeated(w, impacts as u64);
            }
            let headline =
                plan.quantiles[0] && plan.quantiles[2] && (spin.is_some() || plan.quantiles[1]);
            if impacts > 0 && headline {
                // The usual plan: the headline histograms' increments in one
                // scatter loop.
                let (mut ib, mut is, mut io) = ([0u16; BLOCK], [0u16; BLOCK], [0u16; BLOCK]);
                let kr = la
                    .energy_ratio
                    .hist
                    .bin_pass(&d.ratio, &d.impacting, &mut ib);
                let ks = la
                    .velocity_after_norm
                    .hist
                    .bin_pass(&d.speed, &d.impacting, &mut is);
                if spin.is_none() {
                    let ko = la
                        .omega_after_norm
                        .hist
                        .bin_pass(&d.omega, &d.impacting, &mut io);
                    scatter(
                        [
                            la.energy_ratio.hist.positive_bins(),
                            la.velocity_after_norm.hist.positive_bins(),
                            la.omega_after_norm.hist.positive_bins(),
                        ],
                        [&ib, &is, &io],
                        [kr, ks, ko],
                    );
                } else {
                    scatter(
                        [
                            la.energy_ratio.hist.positive_bins(),
                            la.velocity_after_norm.hist.positive_bins(),
                        ],
                        [&ib, &is],
                        [kr, ks],
                    );
                }
            } else if !headline {
                if plan.quantiles[0] {
                    la.energy_ratio.hist.push_weighted(&d.ratio, &d.impacting);
                }
                if plan.quantiles[1] && spin.is_none() {
                    la.omega_after_norm
                        .hist
                        .push_weighted(&d.omega, &d.impacting);
                }
                if plan.quantiles[2] {
                    la.velocity_after_norm
                        .hist
                        .push_weighted(&d.speed, &d.impacting);
                }
            }
        }
        if li == 0 {
            std::mem::swap(first, derived);
        } else {
            let (f, d) = (&**first, &mut **derived);
            let mut both = 0u32;
            for s in 0..BLOCK {
                d.mask[s] = d.impacting[s] * f.impacting[s];
                both += (d.mask[s] > T::ZERO) as u32;
            }
            let p = &mut acc.pairs[li - 1];
            for (k, (target, a, b)) in [
                (&mut p.energy_ratio, &d.ratio, &f.ratio),
                (&mut p.omega_after_norm, &d.omega, &f.omega),
                (&mut p.velocity_after_norm, &d.speed, &f.speed),
            ]
            .into_iter()
            .enumerate()
            {
                if k == 1 && spin.is_some() {
                    target.push_repeated(0.0, both as u64);
                    continue;
                }
                for s in 0..BLOCK {
                    diff[s] = a[s] - b[s];
                }
                target.push_weighted(diff, &d.mask);
            }
        }
    }
}

/// The per-active-set statistics of one law's block (`by_active_set`):
/// moments of the post-impact statistics per set present, and their
/// histograms per set (the "all" histograms are their sums, made by
/// [`RunAcc::finish`]).
#[inline(always)]
fn block_stats_by_set<T: Real, const N: usize>(
    la: &mut LawAcc,
    d: &mut Derived<T, N>,
    count: usize,
    plan: StatsPlan,
    bins: &mut [u16; BLOCK],
) {
    let spin = plan.constant_spin;
    let mut present = [false; 8];
    for s in 0..BLOCK {
        present[d.active[s] as usize & 7] = true;
    }
    for (m, g) in la.groups.iter_mut().enumerate() {
        // Integer counting keeps this loop vectorisable.
        let mut hits = 0u32;
        for s in 0..BLOCK {
            let on = (d.active[s] == m as u32) as u32 & (d.impacting[s] > T::ZERO) as u32;
            d.mask[s] = select(on != 0, T::ONE, T::ZERO);
            hits += on;
        }
        if hits > 0 {
            g.impacts += hits as u64;
            g.energy_ratio.moments.push_weighted(&d.ratio, &d.mask);
            match spin {
                Some(w) => {
                    g.omega_after_norm.moments.push_repeated(w, hits as u64);
                    if plan.quantiles[1] {
                        g.omega_after_norm.hist.push_repeated(w, hits as u64);
                    }
                }
                None => g.omega_after_norm.moments.push_weighted(&d.omega, &d.mask),
            }
            g.velocity_after_norm
                .moments
                .push_weighted(&d.speed, &d.mask);
        }
    }
    // Histograms: bins computed once per statistic (vectorised), each
    // impacting sample counted in its own contact set's histogram.
    for k in 0..3 {
        if !plan.quantiles[k] || (k == 1 && spin.is_some()) {
            continue;
        }
        let xs = [&d.ratio, &d.omega, &d.speed][k];
        let mut other = false;
        let mut negative = false;
        for s in 0..BLOCK {
            bins[s] = LogHistogram::bin_of(xs[s]);
            other |= (d.impacting[s] > T::ZERO) & !(xs[s] > T::ZERO);
            negative |= (d.impacting[s] > T::ZERO) & (xs[s] < T::ZERO);
        }
        // Branch-free: every lane adds its weight (0 or 1) to its set's
        // table, so every set present in the block gets one.
        let mut tables: [Option<&mut [u64; BINS]>; 8] = Default::default();
        for (m, g) in la.groups.iter_mut().enumerate() {
            if present[m] {
                tables[m] = Some(group_stat(g, k).hist.positive_bins());
            }
        }
        for s in 0..BLOCK {
            let on = (d.impacting[s] > T::ZERO) & (xs[s] > T::ZERO);
            if let Some(t) = &mut tables[d.active[s] as usize & 7] {
                t[bins[s] as usize & (BINS - 1)] += on as u64;
            }
        }
        if other {
            // Exact zeros per contact set by compare-and-sum passes (a
            // sphere's |ω⁺| is zero in every lane); negatives one by one.
            for (m, g) in la.groups.iter_mut().enumerate() {
                if !present[m] {
                    continue;
                }
                let mut zeros = 0u32;
                for s in 0..BLOCK {
                    zeros += ((d.active[s] == m as u32)
                        & (d.impacting[s] > T::ZERO)
                        & (xs[s] == T::ZERO)) as u32;
                }
                group_stat(g, k).hist.add_zeros(zeros as u64);
            }
            if negative {
                for s in 0..count {
                    if d.impacting[s] > T::ZERO && xs[s] < T::ZERO {
                        group_stat(&mut la.groups[d.active[s] as usize], k)
                            .hist
                            .push(xs[s].to_f64());
                    }
                }
            }
        }
    }
}

/// Result of a run.
#[derive(Debug, Clone)]
pub struct RunResult {
    /// The finished accumulators of the batches run (all of them unless
    /// sharded).
    pub acc: RunAcc,
    /// A sharded run's merge-tree nodes, unfinished, for `impactmc merge`
    /// (empty otherwise).
    pub nodes: Vec<(Node, RunAcc)>,
    /// Batches in the scene, and how many were run.
    pub batches: u64,
    pub batches_run: u64,
    pub wall_seconds: f64,
    pub cpu_seconds: Option<f64>,
    pub threads: usize,
}

/// Options of a run that do not change its results.
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Worker threads; 0 means all cores.
    pub threads: usize,
    /// Show a progress bar on a terminal.
    pub progress: bool,
    /// Run only this shard's batches.
    pub shard: Option<Shard>,
    /// Effects computed although the scene does not need them (same
    /// answers; for measuring what the specialisation saves).
    pub keep: Keep,
}

/// Batches run per step when per-sample rows are written (rows are
/// delivered in sample order, so memory is bounded by the step).
const BATCHES_IN_FLIGHT_WITH_ROWS: u64 = 2;

/// Receives per-sample rows in sample order.
pub type SampleSink<'a> = dyn FnMut(SampleRows) -> Result<(), String> + Send + 'a;

/// Values shared by the workers of a run (scratch spaces, cleared batch
/// accumulators): taken for a batch and given back, so a run allocates
/// about as many as it uses at once, not one per batch.
struct Pool<W> {
    free: std::sync::Mutex<Vec<W>>,
}

impl<W> Pool<W> {
    fn new() -> Self {
        Self {
            free: std::sync::Mutex::new(Vec::new()),
        }
    }
    fn take(&self, make: impl FnOnce() -> W) -> W {
        let popped = self.free.lock().expect("pool").pop();
        popped.unwrap_or_else(make)
    }
    fn give(&self, w: W) {
        self.free.lock().expect("pool").push(w);
    }
}

/// The maximal merge-tree nodes inside `range`, in batch order (what
/// [`TreeStack`] holds after pushing the range's batches one by one).
fn aligned_nodes(range: std::ops::Range<u64>) -> Vec<Node> {
    let mut nodes = Vec::new();
    let mut b = range.start;
    while b < range.end {
        let mut level = 0;
        while b % (2 << level) == 0 && b + (2 << level) <= range.end {
            level += 1;
        }
        nodes.push(Node {
            level,
            index: b >> level,
        });
        b += 1 << level;
    }
    nodes
}

fn run_typed<T: Real, const N: usize, const ROT: bool, const CPL: bool>(
    scene: &Scene,
    plan: StatsPlan,
    batch_range: std::ops::Range<u64>,
    bar: &indicatif::ProgressBar,
    mut sink: Option<&mut SampleSink>,
) -> Result<Vec<(Node, RunAcc)>, String> {
    let consts = Consts::<T, N>::new(scene);
    // Orientations feed the rotational terms and the per-sample rows only,
    // and the kernel reads only the rows of A its planes need; per-sample
    // rows and planes outside the placement read the whole matrix.
    let whole = sink.is_some() || scene.planes().len() > N;
    let sampler = Sampler::new(scene)
        .with_orientation(ROT || sink.is_some())
        .with_matrix_rows(if whole {
            ALL_ROWS
        } else {
            consts.matrix_rows()
        });
    let laws = scene.laws().len();
    let batch = scene.batch_size();
    let total = scene.samples();
    let (nf, ni) = {
        let (f, i) = sample_columns(scene);
        (f.len(), i.len())
    };
    let want_rows = sink.is_some();
    let ctx = Ctx {
        scene,
        consts: &consts,
        sampler: &sampler,
        plan,
    };
    let pool = Pool::<Work<T, N>>::new();
    // Holds cleared accumulators only.
    let accs = Pool::<RunAcc>::new();
    let run_batch = |b: u64| -> (RunAcc, Option<SampleRows>) {
        let mut work = pool.take(|| Work::new(laws));
        let mut part = accs.take(|| RunAcc::new(laws, N));
        let mut rows = want_rows.then(|| SampleRows::new(nf, ni));
        let lo = b * batch;
        let hi = (lo + batch).min(total);
        let mut first = lo;
        while first < hi {
            let count = ((hi - first) as usize).min(BLOCK);
            run_block::<T, N, ROT, CPL>(&ctx, first, count, &mut work, &mut part, rows.as_mut());
            first += BLOCK as u64;
        }
        part.flush();
        pool.give(work);
        bar.inc(hi - lo);
        (part, rows)
    };
    let mut tree = TreeStack::default();
    if !want_rows {
        // Summary only: each maximal tree node is run as a parallel
        // recursion that merges its two halves as soon as both are done,
        // on whichever thread finished last. Merges overlap with other
        // batches' work (no serial merge step, no barrier), and the tree's
        // shape is fixed by the batch indices, so results are bit-identical
        // for any thread count.
        // A merged right half's accumulator is cleared and reused by a
        // later batch.
        fn subtree(
            node: Node,
            leaf: &(dyn Fn(u64) -> RunAcc + Sync),
            accs: &Pool<RunAcc>,
        ) -> RunAcc {
            if node.level == 0 {
                return leaf(node.index);
            }
            let child = |i| Node {
                level: node.level - 1,
                index: i,
            };
            let (mut left, mut right) = rayon::join(
                || subtree(child(2 * node.index), leaf, accs),
                || subtree(child(2 * node.index + 1), leaf, accs),
            );
            left.merge(&right);
            right.clear();
            accs.give(right);
            left
        }
        let leaf = |b: u64| run_batch(b).0;
        let nodes = aligned_nodes(batch_range);
        let merged: Vec<RunAcc> = nodes
            .par_iter()
            .map(|&node| subtree(node, &leaf, &accs))
            .collect();
        for (node, acc) in nodes.into_iter().zip(merged) {
            tree.push_node(node, acc);
        }
        return Ok(tree.nodes);
    }
    let in_flight = BATCHES_IN_FLIGHT_WITH_ROWS * rayon::current_num_threads() as u64;
    let mut start = batch_range.start;
    while start < batch_range.end {
        let end = (start + in_flight).min(batch_range.end);
        let parts: Vec<(RunAcc, Option<SampleRows>)> =
            (start..end).into_par_iter().map(run_batch).collect();
        for (b, (p, rows)) in (start..end).zip(parts) {
            tree.push(b, p);
            if let (Some(sink), Some(rows)) = (sink.as_mut(), rows) {
                sink(rows)?;
            }
        }
        start = end;
    }
    Ok(tree.nodes)
}

/// A node of the fixed merge tree over batch indices: the batches
/// `[index·2^level, (index + 1)·2^level)`.
///
/// A run's accumulators are merged along this tree, whatever computed
/// them: node = merge(left child, right child), with missing batches past the
/// end empty (merging an empty accumulator is exact: it changes no bit).
/// A shard holds the maximal nodes inside its batch range, and merging
/// shards rebuilds the same tree, so N shards give the single run's answer to
/// the last bit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Node {
    pub level: u32,
    pub index: u64,
}

impl Node {
    /// The batches this node covers.
    pub fn batches(&self) -> std::ops::Range<u64> {
        let lo = self.index << self.level;
        lo..lo + (1u64 << self.level)
    }
}

/// Batch results in batch order, merged as soon as both children of a tree
/// node are complete: what remains are the maximal nodes inside the range
/// seen (at most two per level).
#[derive(Default)]
struct TreeStack {
    nodes: Vec<(Node, RunAcc)>,
}

impl TreeStack {
    fn push(&mut self, batch: u64, acc: RunAcc) {
        self.push_node(
            Node {
                level: 0,
                index: batch,
            },
            acc,
        );
    }

    /// Pushes a complete node (its batches merged along the tree); nodes
    /// come in batch order.
    fn push_node(&mut self, mut node: Node, mut acc: RunAcc) {
        while let Some(&(top, _)) = self.nodes.last() {
            let siblings =
                top.level == node.level && top.index % 2 == 0 && top.index + 1 == node.index;
            if !siblings {
                break;
            }
            let (_, mut left) = self.nodes.pop().expect("checked above");
            left.merge(&acc);
            acc = left;
            node = Node {
                level: node.level + 1,
                index: top.index / 2,
            };
        }
        self.nodes.push((node, acc));
    }
}

/// The root of the merge tree over `batches` batches from nodes that do not
/// overlap. Batches no node covers count as empty; their number is returned
/// with the (unfinished) accumulator.
pub fn reduce_tree(
    nodes: Vec<(Node, RunAcc)>,
    batches: u64,
    laws: usize,
    contacts: usize,
) -> (RunAcc, u64) {
    let mut map: std::collections::HashMap<Node, RunAcc> = nodes.into_iter().collect();
    let mut levels = 0;
    while (1u64 << levels) < batches {
        levels += 1;
    }
    let mut missing = 0;
    let root = reduce_node(
        Node {
            level: levels,
            index: 0,
        },
        batches,
        &mut map,
        &mut missing,
        &|| RunAcc::new(laws, contacts),
    );
    (root, missing)
}

fn reduce_node(
    node: Node,
    batches: u64,
    map: &mut std::collections::HashMap<Node, RunAcc>,
    missing: &mut u64,
    empty: &dyn Fn() -> RunAcc,
) -> RunAcc {
    let range = node.batches();
    if range.start >= batches {
        return empty();
    }
    if let Some(acc) = map.remove(&node) {
        return acc;
    }
    if node.level == 0 {
        *missing += 1;
        return empty();
    }
    let child = |i| Node {
        level: node.level - 1,
        index: i,
    };
    let mut left = reduce_node(child(2 * node.index), batches, map, missing, empty);
    let right = reduce_node(child(2 * node.index + 1), batches, map, missing, empty);
    left.merge(&right);
    left
}

/// Shard `index` of `count`: a contiguous share of the batch indices.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    pub index: u64,
    pub count: u64,
}

impl Shard {
    /// Parses `I/N` (0 ≤ I < N).
    pub fn parse(s: &str) -> Result<Self, String> {
        let (i, n) = s
            .split_once('/')
            .ok_or_else(|| format!("--shard must be I/N (e.g. 3/8), got {s:?}"))?;
        let (index, count): (u64, u64) = match (i.trim().parse(), n.trim().parse()) {
            (Ok(i), Ok(n)) => (i, n),
            _ => return Err(format!("--shard must be I/N with integers, got {s:?}")),
        };
        if count == 0 || index >= count {
            return Err(format!(
                "--shard I/N needs 0 <= I < N, got {s:?} (indices start at 0)"
            ));
        }
        Ok(Self { index, count })
    }

    /// Its batches out of `batches`: `[⌊I·B/N⌋, ⌊(I+1)·B/N⌋)`.
    pub fn batches(&self, batches: u64) -> std::ops::Range<u64> {
        let at = |i: u64| (i as u128 * batches as u128 / self.count as u128) as u64;
        at(self.index)..at(self.index + 1)
    }
}

fn cpu_seconds() -> Option<f64> {
    // /proc/self/stat fields 14 and 15: user and system time in clock ticks.
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let after = stat.rsplit_once(')')?.1;
    let f: Vec<&str> = after.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

/// Why a run stopped.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error("thread pool: {0}")]
    Pool(#[from] rayon::ThreadPoolBuildError),
    #[error("per-sample output: {0}")]
    Sink(String),
}

/// Runs a scene (summary statistics only).
pub fn run(scene: &Scene, opts: &RunOptions) -> Result<RunResult, RunError> {
    run_with_samples(scene, opts, None)
}

/// Runs a scene and hands every sample's row, in sample order, to `sink`.
pub fn run_with_samples(
    scene: &Scene,
    opts: &RunOptions,
    sink: Option<&mut SampleSink>,
) -> Result<RunResult, RunError> {
    let threads = if opts.threads == 0 {
        std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1)
    } else {
        opts.threads
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    let batches = scene.samples().div_ceil(scene.batch_size());
    let range = match opts.shard {
        Some(shard) => shard.batches(batches),
        None => 0..batches,
    };
    let samples_run = (range.end * scene.batch_size()).min(scene.samples())
        - (range.start * scene.batch_size()).min(scene.samples());
    let bar = if opts.progress && samples_run >= 20_000_000 {
        let b = indicatif::ProgressBar::new(samples_run);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{bar:40} {percent:>3}% {human_pos}/{human_len} samples, eta {eta}",
            )
            .expect("static template"),
        );
        b
    } else {
        indicatif::ProgressBar::hidden()
    };
    let cpu0 = cpu_seconds();
    let t0 = Instant::now();
    let r = range.clone();
    let variant = KernelVariant::of(scene, opts.keep);
    let plan = StatsPlan::of(scene, opts.keep);
    let nodes = pool
        .install(|| with_kernel!(scene, variant, run_typed(scene, plan, r, &bar, sink)))
        .map_err(RunError::Sink)?;
    let (laws, contacts) = (scene.laws().len(), scene.touching().len());
    let kept = if opts.shard.is_some() {
        nodes.clone()
    } else {
        Vec::new()
    };
    let (mut acc, _) = reduce_tree(nodes, batches, laws, contacts);
    acc.finish();
    let wall_seconds = t0.elapsed().as_secs_f64();
    bar.finish_and_clear();
    let cpu_seconds = match (cpu0, cpu_seconds()) {
        (Some(a), Some(b)) => Some(b - a),
        _ => None,
    };
    Ok(RunResult {
        acc,
        nodes: kept,
        batches,
        batches_run: range.end - range.start,
        wall_seconds,
        cpu_seconds,
        threads,
    })
}

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
    pub velocity_after: [f64; 3],
    pub omega_after: [f64; 3],
    pub energy_before: f64,
    pub energy_after: f64,
    /// Kernel status bits (see `kernel`).
    pub status: u32,
}

fn evaluate_typed<T: Real, const N: usize, const ROT: bool, const CPL: bool>(
    scene: &Scene,
    law: Law,
    first: u64,
    count: usize,
) -> Vec<SampleOutcome> {
    let consts = Consts::<T, N>::new(scene);
    let sampler = Sampler::new(scene);
    let mut work = Work::<T, N>::new(1);
    let mut out = Vec::with_capacity(count);
    let mut start = first;
    while out.len() < count {
        let n = (count - out.len()).min(BLOCK);
        block_lanes::<T, N, ROT, CPL>(
            &consts,
            &sampler,
            &[law],
            start,
            &mut work.inputs,
            &mut work.geo,
            &mut work.outs,
        );
        fallback(scene, &sampler, &[law], start, &mut work, n);
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
    with_kernel!(scene, variant, evaluate_typed(scene, law, first, count))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every accumulator field by path, as comparable text.
    fn slots(acc: &mut RunAcc) -> Vec<(String, String)> {
        let mut out = Vec::new();
        acc.visit(&mut |path, slot| {
            let value = match slot {
                Slot::Count(c) => format!("count {c}"),
                Slot::Moments(m) => format!("moments {:?}", m.state()),
                Slot::Histogram(h) => format!("hist {:?}", h.entries()),
            };
            out.push((path.to_string(), value));
        });
        out
    }

    /// A run's accumulator, cleared for reuse, is a new one in every field
    /// (and the run had filled fields of every kind).
    #[test]
    fn a_cleared_accumulator_is_a_new_one() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/configs/corner3.toml");
        let scene = crate::scene::load_scene(
            std::path::Path::new(path),
            &crate::scene::Overrides {
                samples: Some(4096),
                laws: Some(vec!["newton".into(), "poisson".into()]),
                ..Default::default()
            },
        )
        .expect("shipped scene");
        let opts = RunOptions {
            threads: 1,
            keep: Keep::ALL,
            ..Default::default()
        };
        let mut used = run(&scene, &opts).expect("run").acc;
        let mut fresh = RunAcc::new(2, 3);
        let (before, want) = (slots(&mut used), slots(&mut fresh));
        assert_eq!(before.len(), want.len());
        for kind in ["count", "moments", "hist"] {
            let changed = before
                .iter()
                .zip(&want)
                .any(|(b, w)| b.1.starts_with(kind) && b != w);
            assert!(changed, "the run filled no {kind} field");
        }
        used.clear();
        assert_eq!(slots(&mut used), want);
    }

    /// The parallel recursion starts from the nodes the batch-by-batch
    /// tree stack ends with, for any batch range (so both build one tree).
    #[test]
    fn aligned_nodes_are_what_the_tree_stack_keeps() {
        for start in 0..40u64 {
            for end in start..start + 70 {
                let mut stack = TreeStack::default();
                for b in start..end {
                    stack.push(b, RunAcc::new(1, 1));
                }
                let kept: Vec<Node> = stack.nodes.iter().map(|(n, _)| *n).collect();
                assert_eq!(aligned_nodes(start..end), kept, "batches {start}..{end}");
            }
        }
    }
}
