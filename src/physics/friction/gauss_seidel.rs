//! The touching contacts of one impact and the Gauss–Seidel laws over them
//! (friction.md §5): `newton` to its limit, `pgsN`, and `paper`.

use glam::{DMat3, DVec3};

use super::delassus;
use super::single::single_contact;
use crate::physics::friction::single::Single;
use crate::physics::Ellipsoid;

/// The touching contacts of one impact, as the frictional laws see them.
#[derive(Debug, Clone)]
pub struct Contacts {
    /// Unit normals, Coulomb coefficients, restitutions.
    pub normals: Vec<DVec3>,
    pub mu: Vec<f64>,
    pub k: Vec<f64>,
    /// Pre-impact contact-point velocities `c⁻_i`.
    pub before: Vec<DVec3>,
    /// Delassus blocks, `w[i][j] = W_ij`.
    pub w: Vec<Vec<DMat3>>,
    /// `|v| + L|ω|` before the impact (m/s), and `m` times it (N·s).
    pub vscale: f64,
    pub pscale: f64,
}

impl Contacts {
    /// Contacts at body-frame points `points` with the given planes' data.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        body: &Ellipsoid,
        rotation: DMat3,
        velocity: DVec3,
        omega: DVec3,
        points: &[DVec3],
        normals: Vec<DVec3>,
        mu: Vec<f64>,
        k: Vec<f64>,
    ) -> Self {
        let before = points
            .iter()
            .map(|&x| velocity + rotation * omega.cross(x))
            .collect();
        let w = points
            .iter()
            .map(|&xi| {
                points
                    .iter()
                    .map(|&xj| delassus(body, rotation, xi, xj))
                    .collect()
            })
            .collect();
        let vscale = velocity.length() + body.length_scale() * omega.length();
        Self {
            normals,
            mu,
            k,
            before,
            w,
            vscale,
            pscale: body.mass() * vscale,
        }
    }

    pub(super) fn len(&self) -> usize {
        self.normals.len()
    }

    /// Newton's normal bias `b_i = k_i min(c⁻_n,i, 0)` (or zero: plastic).
    fn bias(&self, i: usize, plastic: bool) -> f64 {
        if plastic {
            0.0
        } else {
            self.k[i] * self.normals[i].dot(self.before[i]).min(0.0)
        }
    }
}

/// Impulses of a frictional solve and what it flagged.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Solved {
    pub impulses: Vec<DVec3>,
    pub ambiguous: bool,
    pub unsolved: bool,
    /// Newton's Gauss–Seidel did not converge; the plastic (k = 0) one did.
    pub jammed: bool,
    /// Neither converged: the caller uses the frictionless `newton` result.
    pub unconverged: bool,
}

/// Gauss–Seidel sweeps from P = 0: each visit replaces `P_i` by the
/// single-contact solve with `c = c⁻_i + Σ_{j≠i} W_ij P_j`. With
/// `sweeps = None` it runs to the limit (no impulse moved by more than
/// 1e-13 of the impulse scale in a sweep) or 10 000 sweeps; `converged`
/// says which. Flags come from each contact's last visit.
fn gauss_seidel(ct: &Contacts, sweeps: Option<u32>, plastic: bool) -> (Solved, bool) {
    const LIMIT: u32 = 10_000;
    let n = ct.len();
    let mut p = vec![DVec3::ZERO; n];
    let mut last = vec![Single::default(); n];
    let max = sweeps.unwrap_or(LIMIT);
    let mut converged = false;
    for _ in 0..max {
        let mut moved = 0f64;
        for i in 0..n {
            let mut c = ct.before[i];
            for (j, pj) in p.iter().enumerate() {
                if j != i {
                    c += ct.w[i][j] * *pj;
                }
            }
            let s = single_contact(
                c,
                ct.bias(i, plastic),
                &ct.w[i][i],
                ct.normals[i],
                ct.mu[i],
                ct.vscale,
            );
            moved = moved.max((s.impulse - p[i]).length());
            p[i] = s.impulse;
            last[i] = s;
        }
        if sweeps.is_none() && moved <= 1e-13 * ct.pscale {
            converged = true;
            break;
        }
    }
    let solved = Solved {
        impulses: p,
        ambiguous: last.iter().any(|s| s.ambiguous),
        unsolved: last.iter().any(|s| s.unsolved),
        ..Solved::default()
    };
    (solved, converged || sweeps.is_some())
}

/// `newton` with friction: the Gauss–Seidel limit; if it does not
/// converge, the same with every k = 0 (`jammed`); if that does not
/// either, `unconverged` (the caller substitutes the frictionless result).
pub fn newton(ct: &Contacts) -> Solved {
    let (s, ok) = gauss_seidel(ct, None, false);
    if ok {
        return s;
    }
    let (mut s, ok) = gauss_seidel(ct, None, true);
    s.jammed = true;
    if !ok {
        s.unconverged = true;
    }
    s
}

/// `pgsN` with friction: `sweeps` sweeps of the same Gauss–Seidel.
pub fn pgs(ct: &Contacts, sweeps: u32) -> Solved {
    gauss_seidel(ct, Some(sweeps), false).0
}

/// `paper` with friction: each approaching contact alone (its own `c⁻`,
/// `W_ii`), the impulses summed.
pub fn paper(ct: &Contacts) -> Solved {
    let mut out = Solved::default();
    for i in 0..ct.len() {
        let s = if ct.normals[i].dot(ct.before[i]) < 0.0 {
            single_contact(
                ct.before[i],
                ct.bias(i, false),
                &ct.w[i][i],
                ct.normals[i],
                ct.mu[i],
                ct.vscale,
            )
        } else {
            Single::default()
        };
        out.ambiguous |= s.ambiguous;
        out.unsolved |= s.unsolved;
        out.impulses.push(s.impulse);
    }
    out
}
