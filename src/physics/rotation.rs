//! Rotations body → world: Bryan angles `A = Rx(ψ)·Ry(θ)·Rz(φ)` (paper eq.
//! 8–11), unit quaternions and matrices.

use glam::{DMat3, DQuat, DVec3};

/// Bryan angles in radians: `psi` about X, `theta` about Y, `phi` about Z,
/// composed as `A = Rx(ψ)·Ry(θ)·Rz(φ)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bryan {
    pub psi: f64,
    pub theta: f64,
    pub phi: f64,
}

impl Bryan {
    /// `[ψ, θ, φ]` in degrees.
    pub fn degrees(self) -> [f64; 3] {
        [self.psi, self.theta, self.phi].map(f64::to_degrees)
    }
}

fn rx(t: f64) -> DMat3 {
    let (s, c) = t.sin_cos();
    DMat3::from_cols(DVec3::X, DVec3::new(0.0, c, s), DVec3::new(0.0, -s, c))
}

fn ry(t: f64) -> DMat3 {
    let (s, c) = t.sin_cos();
    DMat3::from_cols(DVec3::new(c, 0.0, -s), DVec3::Y, DVec3::new(s, 0.0, c))
}

fn rz(t: f64) -> DMat3 {
    let (s, c) = t.sin_cos();
    DMat3::from_cols(DVec3::new(c, s, 0.0), DVec3::new(-s, c, 0.0), DVec3::Z)
}

/// The unit quaternion of a rotation matrix, with w ≥ 0 (of the two
/// quaternions of a rotation, the one the per-sample rows report).
pub fn quaternion_from_matrix(a: DMat3) -> DQuat {
    let q = DQuat::from_mat3(&a);
    if q.w < 0.0 {
        -q
    } else {
        q
    }
}

/// `A = Rx(ψ)·Ry(θ)·Rz(φ)` (eq. 8–11). With ψ = 45°, θ = 30°, φ = 90° the
/// first row is `(0, −√3/2, 1/2)` (the paper's (xi)).
pub fn matrix_from_bryan(angles: Bryan) -> DMat3 {
    rx(angles.psi) * ry(angles.theta) * rz(angles.phi)
}

/// Rotation matrix of a unit quaternion `w + xi + yj + zk` (normalised here).
pub fn matrix_from_quaternion(q: DQuat) -> DMat3 {
    DMat3::from_quat(q.normalize())
}

/// Bryan angles of a rotation matrix, correct through gimbal lock.
///
/// `θ = atan2(A13, √(A11² + A12²))` is well conditioned everywhere. Away from
/// θ = ±90°, `φ = atan2(−A12, A11)`. Near the lock (`cos θ` below 1e-15) φ is
/// not determined by the matrix, and we choose φ = 0 (the reconstruction
/// error this costs is of order `cos θ`, below 1e-15). ψ is then taken from the
/// residual rotation `A·Rz(φ)ᵀ·Ry(θ)ᵀ = Rx(ψ)`, so the angles always
/// reproduce the matrix, including when ψ and φ only enter as a sum.
pub fn bryan_from_matrix(a: DMat3) -> Bryan {
    // glam is column-major: a.col(j)[i] = A_ij.
    let a11 = a.col(0).x;
    let a12 = a.col(1).x;
    let a13 = a.col(2).x;
    let cos_theta = a11.hypot(a12);
    let theta = a13.atan2(cos_theta);
    let phi = if cos_theta > 1e-15 {
        (-a12).atan2(a11)
    } else {
        0.0
    };
    let residual = a * rz(phi).transpose() * ry(theta).transpose();
    // Rx(ψ) has (2,2) = cos ψ and (3,2) = sin ψ.
    let psi = residual.col(1).z.atan2(residual.col(1).y);
    Bryan { psi, theta, phi }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(m: DMat3, i: usize) -> DVec3 {
        m.row(i)
    }

    #[test]
    fn paper_xi_matrix() {
        let a = matrix_from_bryan(Bryan {
            psi: 45f64.to_radians(),
            theta: 30f64.to_radians(),
            phi: 90f64.to_radians(),
        });
        let s2 = 2f64.sqrt();
        let s3 = 3f64.sqrt();
        let s6 = 6f64.sqrt();
        let want = [
            DVec3::new(0.0, -s3 / 2.0, 0.5),
            DVec3::new(s2 / 2.0, -s2 / 4.0, -s6 / 4.0),
            DVec3::new(s2 / 2.0, s2 / 4.0, s6 / 4.0),
        ];
        for (i, w) in want.iter().enumerate() {
            assert!((row(a, i) - *w).abs().max_element() < 1e-15, "row {i}");
        }
    }

    #[test]
    fn round_trip_through_gimbal_lock() {
        for theta_deg in [-90.0, -89.999999, 0.0, 30.0, 89.9999999999, 90.0] {
            for (psi_deg, phi_deg) in [(10.0, 20.0), (-170.0, 35.0), (0.0, 0.0)] {
                let a = matrix_from_bryan(Bryan {
                    psi: f64::to_radians(psi_deg),
                    theta: f64::to_radians(theta_deg),
                    phi: f64::to_radians(phi_deg),
                });
                let back = matrix_from_bryan(bryan_from_matrix(a));
                let err = (back - a)
                    .to_cols_array()
                    .iter()
                    .fold(0f64, |m, x| m.max(x.abs()));
                assert!(err < 1e-14, "theta {theta_deg}: err {err}");
            }
        }
    }
}
