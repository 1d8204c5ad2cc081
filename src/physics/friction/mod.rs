//! Impacts with Coulomb friction (`docs/spec/friction.md`), f64 reference:
//! the Delassus blocks, the single-contact solve (take-off, stick, slide),
//! the laws `newton` (nonlinear Gauss–Seidel to its limit), `pgsN`,
//! `paper`, and `stronge` (energetic restitution by Darboux–Keller
//! integration in the normal impulse).
//!
//! Impulses here are world vectors `P_i = λ_i n_i + f_i`. The contact-point
//! velocity is `c_i = v + A(ω × x_i)`, and `c⁺_i = c⁻_i + Σ_j W_ij P_j`.
//!
//! - `roots`: Durand–Kerner on the slide angle's quartic;
//! - `single`: the single-contact solve (friction.md §3);
//! - `gauss_seidel`: the contacts of an impact, `newton`, `pgsN`, `paper`;
//! - `stronge`: Darboux–Keller integration for one rough contact.

mod gauss_seidel;
mod roots;
mod single;
mod stronge;

pub(crate) use gauss_seidel::{guard_passes, outer, pattern_newton, JUMP_TOL};
pub use gauss_seidel::{newton, newton_with, paper, pgs, Contacts, Solved};
pub use single::{certified, single_contact, single_contact_full, Case, Single};
pub use stronge::stronge;

use glam::{DMat3, DVec3};

use super::{Ellipsoid, State};

/// friction.md's sticking threshold: a contact with an impulse ends
/// sticking when `|c⁺_t| ≤` this, 1e-9 of the larger velocity scale
/// `|v| + L|ω|` of before and after.
pub fn sticking_threshold(body: &Ellipsoid, before: &State, after: &State) -> f64 {
    let l = body.length_scale();
    1e-9 * (before.velocity.length() + l * before.omega.length())
        .max(after.velocity.length() + l * after.omega.length())
}

/// `[x]×`, the cross-product matrix: `[x]× y = x × y`.
pub(crate) fn skew(x: DVec3) -> DMat3 {
    DMat3::from_cols(
        DVec3::new(0.0, x.z, -x.y),
        DVec3::new(-x.z, 0.0, x.x),
        DVec3::new(x.y, -x.x, 0.0),
    )
}

/// The Delassus block `W_ij = I/m − A [x_i]× J⁻¹ [x_j]× Aᵀ` (world frame,
/// 1/kg) for body-frame contact points `x_i`, `x_j`.
pub fn delassus(body: &Ellipsoid, rotation: DMat3, xi: DVec3, xj: DVec3) -> DMat3 {
    let inv_j = DMat3::from_diagonal(body.inertia().recip());
    DMat3::from_diagonal(DVec3::splat(1.0 / body.mass()))
        - rotation * skew(xi) * inv_j * skew(xj) * rotation.transpose()
}

/// An orthonormal tangent basis of the plane with unit normal `n`.
fn tangent_basis(n: DVec3) -> (DVec3, DVec3) {
    let t1 = n.any_orthonormal_vector();
    (t1, n.cross(t1))
}
