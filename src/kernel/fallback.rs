//! The lanes the fast path cannot vouch for: planes outside the placement,
//! and flagged lanes solved again by the f64 reference.

// Lane code indexes SoA arrays by lane and contact on purpose: the index
// form is what the loop vectoriser sees through.
#![allow(clippy::needless_range_loop, clippy::manual_memcpy)]

use glam::DMat3;

use crate::config::Scene;
use crate::kernel::{Geometry, LawOut, Status};
use crate::lanes::Real;
use crate::physics::{
    solve_impact, ContactOutcome, Ellipsoid, Flags, ImpactOutcome, Law, Pose, State,
};
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
                *status |= Status::NEEDS_REFERENCE;
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
    let mut any = Status::NONE;
    for st in &out.status[..count] {
        any |= *st & Status::NEEDS_REFERENCE;
    }
    if any == Status::NONE {
        return;
    }
    let planes: Vec<_> = scene.planes().iter().map(|p| p.plane).collect();
    for s in 0..count {
        if !out.status[s].has(Status::NEEDS_REFERENCE) {
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
        let mut status = Status::RECOMPUTED;
        let Ok(o) = solve_impact(scene.body(), pose, state, &planes, law, scene.tolerance()) else {
            out.status[s] = status | Status::UNSOLVED;
            continue;
        };
        if o.contacts
            .iter()
            .any(|c| c.geometry.distance < -scene.tolerance())
        {
            status |= Status::PENETRATING;
        }
        write_outcome(&o, &state, scene.body(), scene.touching(), out, s, status);
    }
}

/// One recorded contact of an impact, as a lane records it.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ContactRecord {
    /// Touching and `v_n < 0` before the impact.
    pub approaching: bool,
    /// λ (N·s).
    pub impulse: f64,
    pub normal_velocity_after: f64,
    /// `|f|`, the tangential impulse's magnitude (N·s).
    pub tangential: f64,
    /// `|c⁺_t|` (m/s).
    pub sliding_after: f64,
}

impl From<&ContactOutcome> for ContactRecord {
    fn from(c: &ContactOutcome) -> Self {
        Self {
            approaching: c.approaching,
            impulse: c.impulse,
            normal_velocity_after: c.normal_velocity_after,
            tangential: c.tangential_impulse.length(),
            sliding_after: c.sliding_after,
        }
    }
}

/// Writes a reference outcome into lane `s` of `out`: per recorded contact
/// (`planes`, indices into the outcome's contacts, in lane order) as
/// [`write_record`] does. The contact fallback and the drop reference
/// record impacts through it.
pub fn write_outcome<T: Real, const N: usize>(
    o: &ImpactOutcome,
    before: &State,
    body: &Ellipsoid,
    planes: &[usize],
    out: &mut LawOut<T, N>,
    s: usize,
    status: Status,
) {
    let contacts = planes.iter().map(|&p| ContactRecord::from(&o.contacts[p]));
    let after = (&o.after, o.energy_after, o.flags);
    write_record(after, contacts, before, body, out, s, status);
}

/// Writes an impact into lane `s` of `out`: per recorded contact (in lane
/// order) its impulse, normal velocity after, |f| and |c⁺_t|, and its
/// approaching, active and sticking bits; the velocities and energy
/// after; the impact's flags, over `status`. The one scalar impact
/// recorder: every impact a lane pass did not write itself comes through
/// it, and the block statistics read the lanes alike.
pub fn write_record<T: Real, const N: usize>(
    (after, energy_after, flags): (&State, f64, Flags),
    contacts: impl Iterator<Item = ContactRecord>,
    before: &State,
    body: &Ellipsoid,
    out: &mut LawOut<T, N>,
    s: usize,
    mut status: Status,
) {
    let stuck_at = crate::physics::friction::sticking_threshold(body, before, after);
    for (i, ct) in contacts.enumerate() {
        out.lambda[i][s] = T::from_f64(ct.impulse);
        out.vn_after[i][s] = T::from_f64(ct.normal_velocity_after);
        out.tangential[i][s] = T::from_f64(ct.tangential);
        out.sliding[i][s] = T::from_f64(ct.sliding_after);
        status |= Status::when(ct.impulse > 0.0, Status::active(i))
            | Status::when(ct.approaching, Status::approaching(i))
            | Status::when(
                ct.impulse > 0.0 && ct.sliding_after <= stuck_at,
                Status::sticking(i),
            );
    }
    for k in 0..3 {
        out.v_after[k][s] = T::from_f64(after.velocity[k]);
        out.w_after[k][s] = T::from_f64(after.omega[k]);
    }
    out.t_after[s] = T::from_f64(energy_after);
    status |= flags.to_bits();
    out.status[s] = status;
}
