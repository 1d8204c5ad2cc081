//! The transforms from uniforms to the drawn inputs: Box–Muller normals,
//! Shoemake's Haar orientation, fixed orientations and Bryan angle ranges,
//! written once for every lane type.

use glam::{DMat3, DVec3};

use crate::lanes::Real;

/// Box–Muller: two standard normals from two uniforms in (0, 1).
#[inline(always)]
pub(super) fn box_muller<T: Real>(u1: T, u2: T) -> (T, T) {
    let r = (T::from_f64(-2.0) * u1.ln()).sqrt();
    let (s, c) = u2.sin_cos_2pi_unit();
    (r * c, r * s)
}

/// Shoemake's uniform unit quaternion from three uniforms (Haar on SO(3)),
/// as a rotation matrix, row-major.
#[inline(always)]
pub(super) fn haar_matrix<T: Real>(u1: T, u2: T, u3: T) -> [T; 9] {
    let r1 = (T::ONE - u1).sqrt();
    let r2 = u1.sqrt();
    let (s1, c1) = u2.sin_cos_2pi_unit();
    let (s2, c2) = u3.sin_cos_2pi_unit();
    quaternion_matrix(r2 * c2, r1 * s1, r1 * c1, r2 * s2)
}

/// Rotation matrix (row-major) of the unit quaternion w + xi + yj + zk.
#[inline(always)]
pub(super) fn quaternion_matrix<T: Real>(w: T, x: T, y: T, z: T) -> [T; 9] {
    let two = T::from_f64(2.0);
    let (xx, yy, zz) = (x * x, y * y, z * z);
    let (xy, xz, yz) = (x * y, x * z, y * z);
    let (wx, wy, wz) = (w * x, w * y, w * z);
    [
        T::ONE - two * (yy + zz),
        two * (xy - wz),
        two * (xz + wy),
        two * (xy + wz),
        T::ONE - two * (xx + zz),
        two * (yz - wx),
        two * (xz - wy),
        two * (yz + wx),
        T::ONE - two * (xx + yy),
    ]
}

/// A fixed orientation's matrix, row-major, in the lane type.
pub(super) fn fixed_matrix<T: Real>(a: DMat3) -> [T; 9] {
    a.transpose().to_cols_array().map(T::from_f64)
}

/// The Bryan angle ranges `[low, high]` (radians) as turns: `(low, span)`.
pub(super) fn bryan_turns<T: Real>(low: DVec3, high: DVec3) -> ([T; 3], [T; 3]) {
    let tau = std::f64::consts::TAU;
    (
        (low / tau).to_array().map(T::from_f64),
        ((high - low) / tau).to_array().map(T::from_f64),
    )
}

/// [`bryan_matrix`] at the angles `low + span·u` (turns) for uniforms `u`.
#[inline(always)]
pub(super) fn bryan_matrix_at<T: Real>(lo: [T; 3], span: [T; 3], u: [T; 3]) -> [T; 9] {
    bryan_matrix(
        lo[0] + span[0] * u[0],
        lo[1] + span[1] * u[1],
        lo[2] + span[2] * u[2],
    )
}

/// `Rx(ψ)Ry(θ)Rz(φ)` row-major from angles given as turns (angle / 2π).
#[inline(always)]
pub(super) fn bryan_matrix<T: Real>(psi: T, theta: T, phi: T) -> [T; 9] {
    let (sp, cp) = psi.sin_cos_2pi();
    let (st, ct) = theta.sin_cos_2pi();
    let (sf, cf) = phi.sin_cos_2pi();
    [
        ct * cf,
        -ct * sf,
        st,
        cp * sf + sp * st * cf,
        cp * cf - sp * st * sf,
        -sp * ct,
        sp * sf - cp * st * cf,
        sp * cf + cp * st * sf,
        cp * ct,
    ]
}
