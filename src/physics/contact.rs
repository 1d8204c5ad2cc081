//! Ellipsoid–plane contact in closed form (physics.md, "Planes and the contact
//! point" and "Contact velocity and inertance"): support point, signed
//! distance, lever arm, normal velocity and the inverse inertance G.

use glam::{DMat3, DVec3};

use super::{Ellipsoid, Plane, SymMatrix};

/// Everything about one plane's contact that does not depend on the law.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactGeometry {
    /// Plane normal in the body frame, `u = Aᵀn` (unit).
    pub u: DVec3,
    /// Support distance `h = |D u|` (m): the body's extent toward the plane.
    pub support: f64,
    /// Deepest body point toward the plane, body frame: `x* = −D²u/h` (m).
    pub body_point: DVec3,
    /// The same point in the world frame, `X0 + A x*` (m).
    pub point: DVec3,
    /// Signed distance `d = n·X0 + e − h` (m), negative when penetrating.
    pub distance: f64,
    /// Lever arm in the body frame, `ρ = x* × u` (m) (eq. 26–28).
    pub lever: DVec3,
}

/// `|D u|` without overflow or underflow for extreme semi-axes: the
/// components are scaled by the largest before squaring (hypot-style).
fn support_distance(du: DVec3) -> f64 {
    let scale = du.abs().max_element();
    if scale == 0.0 {
        return 0.0;
    }
    (du / scale).length() * scale
}

impl ContactGeometry {
    /// Contact of `body` at pose (`rotation` body → world, centre `centre`)
    /// with `plane`.
    #[inline]
    pub fn new(body: &Ellipsoid, rotation: DMat3, centre: DVec3, plane: &Plane) -> Self {
        let n = plane.normal();
        let u = rotation.transpose() * n;
        let d = body.semi_axes();
        let du = d * u;
        let support = support_distance(du);
        let body_point = -(d * du) / support;
        // ρ = x* × u with x* = −D²u/h, written so that the differences of
        // squared semi-axes appear explicitly: for a sphere they are exactly
        // zero, so ρ = 0 exactly and ω is untouched by the impact.
        let (a, b, c) = (d.x, d.y, d.z);
        let lever = DVec3::new(
            (b - c) * (b + c) * u.y * u.z,
            (c - a) * (c + a) * u.z * u.x,
            (a - b) * (a + b) * u.x * u.y,
        ) * (-1.0 / support);
        Self {
            u,
            support,
            body_point,
            point: centre + rotation * body_point,
            distance: n.dot(centre) + plane.offset() - support,
            lever,
        }
    }

    /// Normal velocity of the contact point, `v_n = n·v + ρ·ω` (m/s), with
    /// `v` the world centre velocity and `ω` the body-frame angular velocity.
    #[inline]
    pub fn normal_velocity(&self, plane: &Plane, velocity: DVec3, omega_body: DVec3) -> f64 {
        plane.normal().dot(velocity) + self.lever.dot(omega_body)
    }
}

/// Inverse inertance `G_ij = n_i·n_j/m + ρ_iᵀ J⁻¹ ρ_j` (1/kg) over the given
/// contacts: `v_n⁺ = v_n⁻ + G λ`. Symmetric positive semi-definite.
pub fn inverse_inertance(body: &Ellipsoid, normals: &[DVec3], levers: &[DVec3]) -> SymMatrix {
    let n = normals.len();
    let inv_m = 1.0 / body.mass();
    let inv_j = body.inertia().recip();
    let mut g = SymMatrix::zeros(n);
    for i in 0..n {
        for j in 0..=i {
            let value = normals[i].dot(normals[j]) * inv_m + (levers[i] * inv_j).dot(levers[j]);
            g.set(i, j, value);
            g.set(j, i, value);
        }
    }
    g
}

/// The paper's route to the contact point (eq. 51–59), for the accuracy
/// ladder: in the world frame the body is `(X − X0)ᵀ M (X − X0) = 1` with
/// `M = A D⁻² Aᵀ`; the point nearest the plane makes `n` parallel to the
/// gradient, `M (X − X0) = n / (2μ)`. One 3×3 linear solve `M y = n`, then
/// the quadratic `λ² nᵀy = 1` for `X = X0 + λ y`; the root toward the plane
/// is `λ = −1/sqrt(nᵀy)`. Returns the world point and the signed distance.
/// The closed form (`ContactGeometry`) is algebraically the same point;
/// this route loses accuracy as M grows ill-conditioned (extreme aspect
/// ratios), which is what the ladder shows.
pub fn support_point_lagrange(
    body: &Ellipsoid,
    rotation: DMat3,
    centre: DVec3,
    plane: &Plane,
) -> (DVec3, f64) {
    let d = body.semi_axes();
    let dinv2 = DMat3::from_diagonal(1.0 / (d * d));
    let m = rotation * dinv2 * rotation.transpose();
    let n = plane.normal();
    // Gaussian elimination with partial pivoting on [M | n].
    let mut a = [[0.0f64; 4]; 3];
    for (r, row) in a.iter_mut().enumerate() {
        let mr = m.row(r);
        *row = [mr.x, mr.y, mr.z, n[r]];
    }
    for col in 0..3 {
        let piv = (col..3)
            .max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))
            .unwrap_or(col);
        a.swap(col, piv);
        let pivot_row = a[col];
        for row in a.iter_mut().skip(col + 1) {
            let f = row[col] / pivot_row[col];
            for (x, p) in row.iter_mut().zip(pivot_row).skip(col) {
                *x -= f * p;
            }
        }
    }
    let mut y = [0.0f64; 3];
    for r in (0..3).rev() {
        let mut s = a[r][3];
        for c in r + 1..3 {
            s -= a[r][c] * y[c];
        }
        y[r] = s / a[r][r];
    }
    let y = DVec3::from_array(y);
    let lambda = -1.0 / n.dot(y).sqrt();
    let point = centre + y * lambda;
    (point, plane.signed_distance(point))
}

/// Kinetic energy `T = ½m|v|² + ½ωᵀJω` (J), ω in the body frame.
pub fn kinetic_energy(body: &Ellipsoid, velocity: DVec3, omega_body: DVec3) -> f64 {
    0.5 * body.mass() * velocity.length_squared()
        + 0.5 * (body.inertia() * omega_body).dot(omega_body)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::{matrix_from_bryan, Bryan};

    #[test]
    fn paper_section6_touching_positions() {
        // physics.md: X0 = √7/2 and Y0 = √34/4 for the section 6 angles.
        let body = Ellipsoid::new([1.0, 1.0, 2.0], 500.0).unwrap();
        let a = matrix_from_bryan(Bryan {
            psi: 45f64.to_radians(),
            theta: 30f64.to_radians(),
            phi: 90f64.to_radians(),
        });
        let wall_x = Plane::new([1.0, 0.0, 0.0], 0.0, 0.5).unwrap();
        let wall_y = Plane::new([0.0, 1.0, 0.0], 0.0, 0.9).unwrap();
        let hx = ContactGeometry::new(&body, a, DVec3::ZERO, &wall_x).support;
        let hy = ContactGeometry::new(&body, a, DVec3::ZERO, &wall_y).support;
        assert!((hx - 7f64.sqrt() / 2.0).abs() < 1e-15);
        assert!((hy - 34f64.sqrt() / 4.0).abs() < 1e-15);
        // Unrotated (xvi): both are 1 m.
        let h0 = ContactGeometry::new(&body, DMat3::IDENTITY, DVec3::ZERO, &wall_x).support;
        assert_eq!(h0, 1.0);
    }

    #[test]
    fn support_point_lies_on_the_surface_with_normal_along_u() {
        let body = Ellipsoid::new([0.3, 1.7, 4.0], 2.0).unwrap();
        let a = matrix_from_bryan(Bryan {
            psi: 0.3,
            theta: -1.1,
            phi: 2.0,
        });
        let plane = Plane::new([0.2, -0.5, 1.0], 0.0, 0.5).unwrap();
        let g = ContactGeometry::new(&body, a, DVec3::ZERO, &plane);
        let x = g.body_point / body.semi_axes();
        assert!((x.length_squared() - 1.0).abs() < 1e-14);
        // Surface normal ∝ x/D² must be −u.
        let grad = (g.body_point / (body.semi_axes() * body.semi_axes())).normalize();
        assert!((grad + g.u).length() < 1e-14);
    }

    #[test]
    fn sphere_lever_is_exactly_zero() {
        let body = Ellipsoid::new([0.7, 0.7, 0.7], 1.0).unwrap();
        let a = matrix_from_bryan(Bryan {
            psi: 0.1,
            theta: 0.2,
            phi: 0.3,
        });
        let plane = Plane::new([0.3, 0.4, 1.0], 0.0, 0.5).unwrap();
        assert_eq!(
            ContactGeometry::new(&body, a, DVec3::ZERO, &plane).lever,
            DVec3::ZERO
        );
    }

    #[test]
    fn extreme_semi_axes_do_not_overflow() {
        let body = Ellipsoid::new([1e-100, 1e-100, 1e100], 1.0).unwrap();
        let plane = Plane::new([1.0, 1.0, 1.0], 0.0, 0.5).unwrap();
        let g = ContactGeometry::new(&body, DMat3::IDENTITY, DVec3::ZERO, &plane);
        assert!(g.support.is_finite() && g.support > 0.0);
        assert!(g.body_point.is_finite() && g.lever.is_finite());
    }
}
