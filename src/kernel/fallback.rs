//! The lanes the fast path cannot vouch for: planes outside the placement,
//! and flagged lanes solved again by the f64 reference.

// Lane code indexes SoA arrays by lane and contact on purpose: the index
// form is what the loop vectoriser sees through.
#![allow(clippy::needless_range_loop, clippy::manual_memcpy)]

use glam::DMat3;

use crate::config::Scene;
use crate::kernel::{
    active_bit, approaching_bit, bit, sticking_bit, Geometry, LawOut, AMBIGUOUS, DEGENERATE,
    ENERGY_GAIN, JAMMED, PENETRATING, RECOMPUTE, RECOMPUTED, UNCONVERGED, UNSOLVED,
};
use crate::lanes::Real;
use crate::physics::{solve_impact, Ellipsoid, ImpactOutcome, Law, Pose, State};
use crate::sampler::Inputs;
use glam::DVec3;

/// Marks lanes where a plane outside the placement touches or is penetrated
/// (the f64 reference then decides). Scalar, and skipped entirely when every
/// plane of the scene is in the placement.
pub fn check_extra_planes<T: Real, const N: usize>(
    scene: &Scene,
    x: &Inputs<T>,
    geo: &mut Geometry<T, N>,
    count: usize,
) {
    if scene.planes().len() == N {
        return;
    }
    for (s, status) in geo.status.iter_mut().enumerate().take(count) {
        let a = lane_matrix(x, s);
        let centre = scene.centre(a);
        for (j, p) in scene.planes().iter().enumerate() {
            if scene.touching().contains(&j) {
                continue;
            }
            let u = a.transpose() * p.plane.normal();
            let h = (scene.body().semi_axes() * u).length();
            let d = p.plane.signed_distance(centre) - h;
            if d <= scene.tolerance() {
                *status |= RECOMPUTE;
            }
        }
    }
}

pub(crate) fn lane_matrix<T: Real>(x: &Inputs<T>, s: usize) -> DMat3 {
    let r: [f64; 9] = std::array::from_fn(|k| x.a[k][s].to_f64());
    DMat3::from_cols_array(&r).transpose()
}

/// Solves flagged lanes again with the f64 reference on the same inputs and
/// writes the answers back, with the reference's flags (and, with
/// friction, its tangential impulses, sliding speeds and sticking).
pub fn recompute<T: Real, const N: usize>(
    scene: &Scene,
    law: Law,
    x: &Inputs<T>,
    out: &mut LawOut<T, N>,
    count: usize,
) {
    // Most blocks have no flagged lane: one vectorised test first.
    let mut any = 0u32;
    for st in &out.status[..count] {
        any |= st & RECOMPUTE;
    }
    if any == 0 {
        return;
    }
    let planes: Vec<_> = scene.planes().iter().map(|p| p.plane).collect();
    for s in 0..count {
        if out.status[s] & RECOMPUTE == 0 {
            continue;
        }
        let a = lane_matrix(x, s);
        let state = State {
            velocity: DVec3::new(x.v[0][s].to_f64(), x.v[1][s].to_f64(), x.v[2][s].to_f64()),
            omega: DVec3::new(x.w[0][s].to_f64(), x.w[1][s].to_f64(), x.w[2][s].to_f64()),
        };
        let pose = Pose {
            rotation: a,
            centre: scene.centre(a),
        };
        let mut status = RECOMPUTED;
        let Ok(o) = solve_impact(scene.body(), pose, state, &planes, law, scene.tolerance()) else {
            out.status[s] = status | UNSOLVED;
            continue;
        };
        if o.contacts
            .iter()
            .any(|c| c.geometry.distance < -scene.tolerance())
        {
            status |= PENETRATING;
        }
        write_outcome(&o, &state, scene.body(), scene.touching(), out, s, status);
    }
}

/// Writes a reference outcome into lane `s` of `out`: per recorded contact
/// (`planes`, indices into the outcome's contacts, in lane order) its
/// impulse, normal velocity after, |f| and |c⁺_t|, and its approaching,
/// active and sticking bits; the velocities and energy after; the
/// outcome's flags, over `status`. The one scalar impact recorder: the
/// contact fallback and the drop body both record impacts through it, and
/// the block statistics read the lanes alike.
pub fn write_outcome<T: Real, const N: usize>(
    o: &ImpactOutcome,
    before: &State,
    body: &Ellipsoid,
    planes: &[usize],
    out: &mut LawOut<T, N>,
    s: usize,
    mut status: u32,
) {
    let stuck_at = crate::physics::friction::sticking_threshold(body, before, &o.after);
    for (i, &p) in planes.iter().enumerate() {
        let ct = &o.contacts[p];
        out.lambda[i][s] = T::from_f64(ct.impulse);
        out.vn_after[i][s] = T::from_f64(ct.normal_velocity_after);
        out.tangential[i][s] = T::from_f64(ct.tangential_impulse.length());
        out.sliding[i][s] = T::from_f64(ct.sliding_after);
        status |= bit(ct.impulse > 0.0, active_bit(i))
            | bit(ct.approaching, approaching_bit(i))
            | bit(
                ct.impulse > 0.0 && ct.sliding_after <= stuck_at,
                sticking_bit(i),
            );
    }
    for k in 0..3 {
        out.v_after[k][s] = T::from_f64(o.after.velocity[k]);
        out.w_after[k][s] = T::from_f64(o.after.omega[k]);
    }
    out.t_after[s] = T::from_f64(o.energy_after);
    status |= bit(o.flags.energy_gain, ENERGY_GAIN)
        | bit(o.flags.degenerate, DEGENERATE)
        | bit(o.flags.jammed, JAMMED)
        | bit(o.flags.unsolved, UNSOLVED)
        | bit(o.flags.ambiguous, AMBIGUOUS)
        | bit(o.flags.unconverged, UNCONVERGED);
    out.status[s] = status;
}
