//! Velocities, energies and friction statistics after the frictional
//! impulses of a block.

// Lane code indexes SoA arrays by lane and contact on purpose: the index
// form is what the loop vectoriser sees through.
#![allow(clippy::needless_range_loop, clippy::manual_memcpy)]

use crate::kernel::friction::state::{Frame, Sweep, MOVED_SHIFT, STICK_SHIFT, UNSURE};
use crate::kernel::geometry::dot3;
use crate::kernel::{Consts, Geometry, LawOut, Status};
use crate::lanes::dispatch::BLOCK;
use crate::lanes::{select, Real};
use crate::sampler::Inputs;

/// Post-impact velocities, normal velocities, energy, tangential impulses
/// and sliding speeds of a frictional block (`limit`: the impulses are
/// Newton's converged limit); lanes the solve could not vouch for are
/// flagged [`Status::NEEDS_REFERENCE`].
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(super) fn friction_post<T: Real, const N: usize>(
    c: &Consts<T, N>,
    x: &Inputs<T>,
    geo: &Geometry<T, N>,
    fr: &Frame<T, N>,
    sw: &Sweep<T, N>,
    limit: bool,
    unconverged: &[bool; BLOCK],
    out: &mut LawOut<T, N>,
) {
    let stick_speed = T::from_f64(1e-9);
    for s in 0..BLOCK {
        let dv = [sw.dv[0][s], sw.dv[1][s], sw.dv[2][s]];
        let dw = [sw.dw[0][s], sw.dw[1][s], sw.dw[2][s]];
        let v: [T; 3] = std::array::from_fn(|k| x.v[k][s] + dv[k]);
        let w: [T; 3] = std::array::from_fn(|k| x.w[k][s] + dw[k]);
        let vscale_after = c.length.mul_add(dot3(w, w).sqrt(), dot3(v, v).sqrt());
        let stuck_at = stick_speed * fr.vscale[s].max(vscale_after);
        let mut status = geo.status[s];
        let mut work = T::ZERO;
        let mut work_abs = T::ZERO;
        let mut unsure_stick = false;
        for i in 0..N {
            let dirs = [c.normal[i], c.fr.tangent[i][0], c.fr.tangent[i][1]];
            let mut after = [T::ZERO; 3];
            for d in 0..3 {
                let lever = [
                    fr.lever[i][d][0][s],
                    fr.lever[i][d][1][s],
                    fr.lever[i][d][2][s],
                ];
                after[d] = fr.c0[i][d][s] + dot3(dirs[d], dv) + dot3(lever, dw);
                let p = sw.p[i][d][s];
                let before = fr.c0[i][d][s];
                work = p.mul_add(before + after[d], work);
                work_abs = p.abs().mul_add(before.abs() + after[d].abs(), work_abs);
            }
            let lambda = sw.p[i][0][s];
            // friction.md's sticking: |c⁺_t| ≤ 1e-9 × the velocity scale.
            // A contact whose last visit stuck has c⁺_t = 0 if nothing moved
            // since, or at Newton's limit (whose stopping rule leaves far
            // less than the threshold); otherwise the computed speed
            // decides, unless it is within rounding of the threshold.
            let stuck = sw.bits[s] & (1 << (STICK_SHIFT + i as u32)) != 0;
            let since = sw.bits[s] & (1 << (MOVED_SHIFT + i as u32)) != 0;
            let speed = after[1].mul_add(after[1], after[2] * after[2]).sqrt();
            let rounding = c.fr.take_off_band * fr.vscale[s];
            let at_rest = stuck & (limit | !since);
            let sliding = select(at_rest, T::ZERO, speed);
            let active = lambda > T::ZERO;
            unsure_stick |= active & !at_rest & ((speed - stuck_at).abs() <= rounding);
            out.lambda[i][s] = lambda;
            out.vn_after[i][s] = after[0];
            out.tangential[i][s] = sw.p[i][1][s]
                .mul_add(sw.p[i][1][s], sw.p[i][2][s] * sw.p[i][2][s])
                .sqrt();
            out.sliding[i][s] = sliding;
            status |= Status::when(lambda > T::ZERO, Status::active(i));
            status |= Status::when(
                active & (at_rest | (speed <= stuck_at)),
                Status::sticking(i),
            );
        }
        // ΔT = ½ Σ P_i·(c⁻_i + c⁺_i), exact for any impulses (friction.md).
        let (t1, gained, unsure) =
            crate::kernel::impulses::energy_after(c, geo.t_before[s], v, w, work, work_abs);
        for k in 0..3 {
            out.v_after[k][s] = v[k];
            out.w_after[k][s] = w[k];
        }
        out.t_after[s] = t1;
        status |= Status::when(gained, Status::ENERGY_GAIN)
            | Status::when(
                unsure | unsure_stick | unconverged[s] | (sw.bits[s] & UNSURE != 0),
                Status::NEEDS_REFERENCE,
            );
        out.status[s] = status;
    }
}
