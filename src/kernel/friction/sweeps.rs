//! The laws as visits of the single-contact solve: Gauss–Seidel sweeps
//! for `newton` (to its stopping rule) and `pgsN`, one visit per contact for
//! `paper` (friction.md §5).

// Lane code indexes SoA arrays by lane and contact on purpose: the index
// form is what the loop vectoriser sees through.
#![allow(clippy::needless_range_loop, clippy::manual_memcpy)]

use super::accelerate::Acceleration;
use crate::kernel::friction::post::friction_post;
use crate::kernel::friction::slide::{
    certified_settle, certified_start, certified_step, finish, grid_setup, interval, restart,
    root_judge, root_start, root_step, setup,
};
use crate::kernel::friction::state::{Frame, Sweep, GRID, UNSURE};
use crate::kernel::{Consts, Geometry, LawOut};
use crate::lanes::dispatch::BLOCK;
use crate::lanes::Real;
use crate::physics::Law;
use crate::sampler::Inputs;

/// One visit of contact i in every lane (friction.md's single-contact
/// solve, or with μ = 0 its closed form).
#[inline(always)]
pub(super) fn visit<T: Real, const N: usize, const COUPLED: bool>(
    c: &Consts<T, N>,
    i: usize,
    fr: &Frame<T, N>,
    sw: &mut Sweep<T, N>,
    lanes: usize,
) {
    let fc = &c.fr;
    setup::<T, N, COUPLED>(c, i, fr, sw, lanes);
    if fc.mu[i] == T::ZERO {
        finish::<T, N, COUPLED, false>(c, i, fr, sw, lanes);
        return;
    }
    let k = &mut sw.solve;
    if fr.b3_all[i] {
        // B3 in every lane: one root from the start direction, unless a
        // lane is left undecided (then the full search below, afresh).
        certified_start(k, lanes);
        for _ in 0..fc.certified_steps {
            certified_step(k, lanes);
        }
        root_judge(fc, fc.mu[i], i, 0, fr, k, lanes);
        if certified_settle(k, lanes) {
            finish::<T, N, COUPLED, true>(c, i, fr, sw, lanes);
            return;
        }
        restart(k, lanes);
    }
    grid_setup(fc, k, lanes);
    for j in 0..GRID {
        interval(fc, j, k, lanes);
    }
    let iters = if T::EPSILON.to_f64() > 1e-10 { 5 } else { 8 };
    for n in 0..4 {
        // Blocks where no lane has this many roots skip it (no lane's
        // answer changes).
        let used = k.changes[..lanes]
            .iter()
            .any(|&x| x > T::from_f64(n as f64));
        if !used {
            break;
        }
        root_start(fc, n, k, lanes);
        for _ in 0..iters {
            root_step(n, k, lanes);
        }
        root_judge(fc, fc.mu[i], i, n, fr, k, lanes);
    }
    finish::<T, N, COUPLED, true>(c, i, fr, sw, lanes);
}

/// Every contact visited once, in scene order, in the first `lanes`
/// lanes. (A whole block is passed as the constant [`BLOCK`], so that its
/// passes are compiled for that count: a count known only at run time
/// costs the full-width passes most of their speed.)
#[inline(always)]
pub(super) fn sweep<T: Real, const N: usize, const COUPLED: bool>(
    c: &Consts<T, N>,
    fr: &Frame<T, N>,
    sw: &mut Sweep<T, N>,
    lanes: usize,
) {
    for i in 0..N {
        visit::<T, N, COUPLED>(c, i, fr, sw, lanes);
    }
}

/// The impulses of a frictional law on a block, then the post-impact
/// quantities into `out` (as [`post`](crate::kernel::post) does without friction), with the
/// tangential impulse and sliding speed per contact.
#[inline(always)]
pub fn friction_impulses<T: Real, const N: usize>(
    c: &Consts<T, N>,
    law: Law,
    x: &Inputs<T>,
    geo: &Geometry<T, N>,
    fr: &mut Frame<T, N>,
    sw: &mut Sweep<T, N>,
    out: &mut LawOut<T, N>,
) {
    for i in 0..N {
        for d in 0..3 {
            sw.p[i][d] = [T::ZERO; BLOCK];
        }
    }
    for k in 0..3 {
        sw.dv[k] = [T::ZERO; BLOCK];
        sw.dw[k] = [T::ZERO; BLOCK];
    }
    sw.bits = [0; BLOCK];
    let mut unconverged = [false; BLOCK];
    match law {
        // Each approaching contact alone: its own c⁻ (paper with friction).
        Law::Paper => sweep::<T, N, false>(c, fr, sw, BLOCK),
        Law::Pgs { sweeps } => {
            for _ in 0..sweeps {
                sweep::<T, N, true>(c, fr, sw, BLOCK);
            }
        }
        // Stronge's Darboux–Keller integration runs per sample in the f64
        // reference.
        Law::Stronge => sw.bits = [UNSURE; BLOCK],
        // One contact: a single visit is the limit (a second moves nothing).
        Law::Newton if N == 1 => sweep::<T, N, true>(c, fr, sw, BLOCK),
        // Several contacts: sweeps until no impulse moves by more than the
        // tolerance (friction.md's stopping rule). The limit is what the
        // certificate must vouch for: a lane is kept when every visit of its
        // last sweep was certain and that sweep moved nothing, so that its
        // impulses satisfy every contact's law; earlier visits only lead
        // there. Each lane stops at its own first such sweep, and the lanes
        // still sweeping are compacted into as few vectors as hold them
        // (`compact::Queue`), so that a block does not sweep at full width for its
        // slowest lanes.
        Law::Newton => {
            let mass = c.mass;
            let mut acc =
                c.fr.accelerate
                    .then(|| Acceleration::<T, N>::new(c.fr.accelerate_period));
            let mut queue = sw.queue.take().expect("the sweep's queue is in place");
            queue.start(fr);
            for t in 1..=c.fr.gs_max {
                if let Some(a) = acc.as_mut() {
                    a.before_sweep(t, sw);
                }
                sw.moved = [T::ZERO; BLOCK];
                for b in sw.bits.iter_mut() {
                    *b &= !UNSURE;
                }
                match sw.solve.len {
                    BLOCK => sweep::<T, N, true>(c, fr, sw, BLOCK),
                    lanes => sweep::<T, N, true>(c, fr, sw, lanes.min(BLOCK)),
                }
                let mut left = 0u32;
                for s in 0..sw.solve.len.min(BLOCK) {
                    let still = sw.moved[s] > c.fr.gs_tol * mass * fr.vscale[s];
                    unconverged[s] = still;
                    left |= still as u32;
                }
                if let Some(a) = acc.as_mut() {
                    // Jumps that the sweep did not confirm are undone.
                    left |= a.after_sweep(t, c, fr, sw, &unconverged) as u32;
                }
                queue.settle(sw, &unconverged);
                if left == 0 {
                    break;
                }
                queue.compact(fr, sw, acc.as_mut(), &mut unconverged);
            }
            queue.finish(fr, sw, &mut unconverged);
            sw.queue = Some(queue);
        }
        Law::Poisson => unreachable!("poisson with friction is refused by the scene"),
    }
    let limit = matches!(law, Law::Newton);
    friction_post(c, x, geo, fr, sw, limit, &unconverged, out);
}
