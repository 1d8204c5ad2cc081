//! One batch of a run: SoA blocks through sampler → kernel → f64 fallback
//! → statistics (and per-sample rows, when asked for).

// Lane code indexes SoA arrays by lane and contact on purpose: the index
// form is what the loop vectoriser sees through.
#![allow(clippy::needless_range_loop, clippy::manual_memcpy)]

use crate::config::Scene;
use glam::DMat3;

use crate::kernel::{
    check_extra_planes, frame, friction_impulses, geometry, impulses, post, recompute, Consts,
    Frame, Geometry, LawOut, Status, Sweep,
};
use crate::lanes::dispatch::{multiversioned, BLOCK};
use crate::lanes::Real;
use crate::output::columns::Field;
use crate::output::samples::SampleRows;
use crate::physics::{bryan_from_matrix, quaternion_from_matrix, Law};
use crate::sampler::{Inputs, Sampler};
use crate::stats::accumulators::RunAcc;
use crate::stats::block::record_friction;
use crate::stats::block::{block_stats, Before, Scratch, StatsPlan};

/// Scratch space of one worker: taken from the run's pool for a batch and
/// returned after it, so a worker allocates it once per run.
pub(crate) struct Work<T, const N: usize> {
    pub(crate) inputs: Box<Inputs<T>>,
    pub(crate) geo: Box<Geometry<T, N>>,
    pub(crate) outs: Vec<Box<LawOut<T, N>>>,
    /// With friction: the contact frames and the Gauss–Seidel state.
    pub(crate) frame: Box<Frame<T, N>>,
    pub(crate) sweep: Box<Sweep<T, N>>,
    pub(crate) stats: Scratch<T, N>,
}

impl<T: Real, const N: usize> Work<T, N> {
    pub(crate) fn new(laws: usize) -> Self {
        Self {
            inputs: Inputs::new(),
            geo: Geometry::new(),
            outs: (0..laws).map(|_| LawOut::new()).collect(),
            frame: Frame::new(),
            sweep: Sweep::new(),
            stats: Scratch::new(),
        }
    }
}

multiversioned! {
    /// The vectorised part of a block: draws, geometry, impulses and post
    /// quantities for every law. Compiled for AVX-512, AVX2+FMA and the
    /// baseline; the best the CPU has is chosen at run time. The frictional
    /// variant (`FR`, always with `ROT` and `CPL`) runs the frictional
    /// passes instead of the frictionless ones.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn block_lanes<
        T: Real,
        const N: usize,
        const ROT: bool,
        const CPL: bool,
        const FR: bool,
    >(
        consts: &Consts<T, N>,
        sampler: &Sampler,
        laws: &[Law],
        first: u64,
        inputs: &mut Inputs<T>,
        geo: &mut Geometry<T, N>,
        outs: &mut [Box<LawOut<T, N>>],
        fr: &mut Frame<T, N>,
        sweep: &mut Sweep<T, N>,
    ) {
        crate::lanes::dispatch::align_frame();
        sampler.fill(first, inputs);
        if FR {
            friction_frame::<T, N>(consts, inputs, fr, geo);
            for (law, out) in laws.iter().zip(outs.iter_mut()) {
                friction_law::<T, N>(consts, *law, inputs, geo, fr, sweep, out);
            }
            return;
        }
        let newton_only = CPL && laws.iter().all(|l| matches!(l, Law::Newton));
        geometry::<T, N, ROT>(consts, inputs, geo, !newton_only);
        for (law, out) in laws.iter().zip(outs.iter_mut()) {
            impulses::<T, N, ROT, CPL>(consts, *law, geo, out);
            post::<T, N, ROT>(consts, inputs, geo, out);
        }
    }
}

multiversioned! {
    /// The contact frames of a frictional block (its own entry point, so
    /// that every array it touches comes through a reference of its own and
    /// the loops vectorise).
    fn friction_frame<T: Real, const N: usize>(
        consts: &Consts<T, N>,
        inputs: &Inputs<T>,
        fr: &mut Frame<T, N>,
        geo: &mut Geometry<T, N>,
    ) {
        crate::lanes::dispatch::align_frame();
        frame::<T, N>(consts, inputs, fr, geo);
    }
}

multiversioned! {
    /// One frictional law on a block: impulses and post-impact quantities.
    fn friction_law<T: Real, const N: usize>(
        consts: &Consts<T, N>,
        law: Law,
        inputs: &Inputs<T>,
        geo: &Geometry<T, N>,
        fr: &mut Frame<T, N>,
        sweep: &mut Sweep<T, N>,
        out: &mut LawOut<T, N>,
    ) {
        crate::lanes::dispatch::align_frame();
        friction_impulses::<T, N>(consts, law, inputs, geo, fr, sweep, out);
    }
}

multiversioned! {
    /// The contact kernel alone on a block of given inputs (geometry, one law's
    /// impulses, post-impact quantities), with the same run-time dispatch as a
    /// run. For benchmarks that compare kernel designs on identical inputs.
    pub fn kernel_block<T: Real, const N: usize, const ROT: bool, const CPL: bool>(
        consts: &Consts<T, N>,
        law: Law,
        inputs: &Inputs<T>,
        geo: &mut Geometry<T, N>,
        out: &mut LawOut<T, N>,
    ) {
        crate::lanes::dispatch::align_frame();
        geometry::<T, N, ROT>(consts, inputs, geo, !(CPL && matches!(law, Law::Newton)));
        impulses::<T, N, ROT, CPL>(consts, law, geo, out);
        post::<T, N, ROT>(consts, inputs, geo, out);
    }
}

multiversioned! {
    /// The sampler alone on one block, with the same run-time dispatch as a
    /// run. For benchmarks of the draws.
    pub fn sample_block<T: Real>(sampler: &Sampler, first: u64, inputs: &mut Inputs<T>) {
        crate::lanes::dispatch::align_frame();
        sampler.fill(first, inputs);
    }
}

/// One block: the lane passes, then the reference for flagged lanes, then the
/// accumulators (scalar).
/// What every block of a run shares.
pub(crate) struct Ctx<'a, T, const N: usize> {
    pub(crate) scene: &'a Scene,
    pub(crate) consts: &'a Consts<T, N>,
    pub(crate) sampler: &'a Sampler,
    pub(crate) plan: StatsPlan,
}

pub(crate) fn run_block<
    T: Real,
    const N: usize,
    const ROT: bool,
    const CPL: bool,
    const FR: bool,
>(
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
    block_lanes::<T, N, ROT, CPL, FR>(
        consts,
        sampler,
        laws,
        first,
        &mut work.inputs,
        &mut work.geo,
        &mut work.outs,
        &mut work.frame,
        &mut work.sweep,
    );
    fallback(scene, sampler, laws, first, work, count, Some(&mut *acc));
    block_stats(
        &[Before::of(&work.geo)],
        &work.outs,
        count,
        ctx.plan,
        &mut work.stats,
        acc,
    );
    if let Some(rows) = rows {
        push_rows(&work.inputs, &work.geo, &work.outs, (first, count), rows);
    }
}

/// The scalar part after the lane passes, for every law of a block: planes
/// outside the placement are checked (only in scenes that have them), and
/// flagged lanes are solved again by the f64 reference.
pub(crate) fn fallback<T: Real, const N: usize>(
    scene: &Scene,
    sampler: &Sampler,
    laws: &[Law],
    first: u64,
    work: &mut Work<T, N>,
    count: usize,
    mut acc: Option<&mut RunAcc>,
) {
    let extra_planes = scene.planes().len() > N;
    if extra_planes {
        check_extra_planes(scene, &work.inputs, &mut work.geo, count);
    }
    if sampler.partial_rows() {
        // The reference reads the whole orientation of a flagged lane: its
        // unwritten rows, as the full fill would have written them.
        let mut flagged = Status::NONE;
        for out in work.outs.iter() {
            for st in &out.status[..count] {
                flagged |= *st & Status::NEEDS_REFERENCE;
            }
        }
        if flagged != Status::NONE {
            for s in 0..count {
                if work
                    .outs
                    .iter()
                    .any(|o| o.status[s].has(Status::NEEDS_REFERENCE))
                {
                    let a = sampler.orientation_of::<T>(first + s as u64);
                    for (k, ak) in a.into_iter().enumerate() {
                        work.inputs.a[k][s] = ak;
                    }
                }
            }
        }
    }
    for (l, (law, out)) in laws.iter().zip(work.outs.iter_mut()).enumerate() {
        if extra_planes {
            // Extra-plane checks landed in geo.status after the lane passes.
            for s in 0..count {
                out.status[s] |= work.geo.status[s] & Status::NEEDS_REFERENCE;
            }
        }
        recompute(scene, *law, &work.inputs, out, count);
        if let Some(fr) = acc.as_deref_mut().and_then(|a| a.laws[l].friction.as_mut()) {
            record_friction(out, count, fr);
        }
    }
}

/// Appends a block's rows (after recomputation): each column of the
/// [`RowLayout`](crate::output::columns::RowLayout) gets the lanes its
/// [`Field`] names.
pub(crate) fn push_rows<T: Real, const N: usize>(
    x: &Inputs<T>,
    geo: &Geometry<T, N>,
    outs: &[Box<LawOut<T, N>>],
    (first, count): (u64, usize),
    rows: &mut SampleRows,
) {
    rows.index.extend(first..first + count as u64);
    // The orientation as a unit quaternion with w ≥ 0, from the matrix the
    // kernel used.
    // The orientation as a unit quaternion with w ≥ 0, and as Bryan angles
    // (degrees), from the matrix the kernel used.
    let mut q = [[0.0f64; 4]; BLOCK];
    let mut bryan = [[0.0f64; 3]; BLOCK];
    let quaternion = rows.fills_any(|f| matches!(f, Field::Quaternion(_)));
    let angles = rows.fills_any(|f| matches!(f, Field::Bryan(_)));
    for s in 0..count * (quaternion || angles) as usize {
        let a = DMat3::from_cols_array(&std::array::from_fn(|k| x.a[k][s].to_f64())).transpose();
        if quaternion {
            let r = quaternion_from_matrix(a);
            q[s] = [r.w, r.x, r.y, r.z];
        }
        if angles {
            bryan[s] = bryan_from_matrix(a).degrees();
        }
    }
    fn lane<T: Real>(c: &[T; BLOCK], count: usize) -> impl Iterator<Item = f64> + '_ {
        c[..count].iter().map(|v| v.to_f64())
    }
    for (k, field) in rows.float_fields().iter().enumerate() {
        match *field {
            Field::Quaternion(c) => rows.put(k, q[..count].iter().map(|q| q[c])),
            Field::Bryan(c) => rows.put(k, bryan[..count].iter().map(|b| b[c])),
            Field::Velocity(c) => rows.put(k, lane(&x.v[c], count)),
            Field::Omega(c) => rows.put(k, lane(&x.w[c], count)),
            Field::EnergyBefore => rows.put(k, lane(&geo.t_before, count)),
            Field::VnBefore { plane } => rows.put(k, lane(&geo.vn[plane], count)),
            Field::EnergyAfter { law } => rows.put(k, lane(&outs[law].t_after, count)),
            Field::EnergyRatio { law } => rows.put(
                k,
                lane(&outs[law].t_after, count)
                    .zip(lane(&geo.t_before, count))
                    .map(|(t1, t0)| t1 / t0),
            ),
            Field::VelocityAfter { law, axis } => {
                rows.put(k, lane(&outs[law].v_after[axis], count))
            }
            Field::OmegaAfter { law, axis } => rows.put(k, lane(&outs[law].w_after[axis], count)),
            Field::Impulse { law, plane } => rows.put(k, lane(&outs[law].lambda[plane], count)),
            Field::VnAfter { law, plane } => rows.put(k, lane(&outs[law].vn_after[plane], count)),
            Field::TangentialImpulse { law, plane } => {
                rows.put(k, lane(&outs[law].tangential[plane], count))
            }
            Field::SlidingSpeed { law, plane } => {
                rows.put(k, lane(&outs[law].sliding[plane], count))
            }
            f => unreachable!("{f:?} is not a contact row's float column"),
        }
    }
    for (k, field) in rows.int_fields().iter().enumerate() {
        let status = |law: usize| outs[law].status[..count].iter();
        let column = &mut rows.ints[k];
        match *field {
            Field::Active { law } => {
                column.extend(status(law).map(|st| st.active_mask::<N>() as u16))
            }
            // As the statistics count an impact (`stats::block`).
            Field::Impacted { law } => column.extend(status(law).map(|st| {
                (st.approaching_mask::<N>() != 0 && !st.has(Status::PENETRATING)) as u16
            })),
            // Bits 0–14 (a u16 holds them); the friction bits above have
            // their own columns.
            Field::Flags { law } => column.extend(status(law).map(|st| st.bits() as u16)),
            Field::Sticking { law } => {
                column.extend(status(law).map(|st| st.sticking_mask::<N>() as u16))
            }
            Field::FrictionFlags { law } => column.extend(status(law).map(|st| {
                st.has(Status::AMBIGUOUS) as u16 | (st.has(Status::UNCONVERGED) as u16) << 1
            })),
            f => unreachable!("{f:?} is not a contact row's integer column"),
        }
    }
}
