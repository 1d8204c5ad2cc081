//! The rigid ellipsoid: semi-axes, mass and principal inertia (paper eq. 1).

use glam::{DMat3, DVec3};

/// Why an ellipsoid could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BodyError {
    /// A semi-axis is not a finite number greater than zero.
    #[error("semi-axis {index} must be a finite number > 0, got {value}")]
    SemiAxis { index: usize, value: f64 },
    /// The mass is not a finite number greater than zero.
    #[error("mass must be a finite number > 0, got {0}")]
    Mass(f64),
}

/// A homogeneous solid ellipsoid with semi-axes `a, b, c` (m) on the body
/// x, y, z axes and mass `m` (kg). Fields are private: a value that exists is
/// valid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ellipsoid {
    semi_axes: DVec3,
    mass: f64,
    inertia: DVec3,
}

impl Ellipsoid {
    /// Validating constructor. NaN-safe: `!(x > 0)` rejects NaN too.
    pub fn new(semi_axes: [f64; 3], mass: f64) -> Result<Self, BodyError> {
        for (index, &value) in semi_axes.iter().enumerate() {
            if !(value > 0.0 && value.is_finite()) {
                return Err(BodyError::SemiAxis { index, value });
            }
        }
        if !(mass > 0.0 && mass.is_finite()) {
            return Err(BodyError::Mass(mass));
        }
        let [a, b, c] = semi_axes;
        // Eq. 1: J = diag(m(b²+c²)/5, m(c²+a²)/5, m(a²+b²)/5), kg·m².
        let inertia = DVec3::new(
            mass * (b * b + c * c) / 5.0,
            mass * (c * c + a * a) / 5.0,
            mass * (a * a + b * b) / 5.0,
        );
        Ok(Self {
            semi_axes: DVec3::from_array(semi_axes),
            mass,
            inertia,
        })
    }

    /// Semi-axes `(a, b, c)` in metres.
    pub fn semi_axes(&self) -> DVec3 {
        self.semi_axes
    }

    /// Mass in kg.
    pub fn mass(&self) -> f64 {
        self.mass
    }

    /// Principal moments of inertia `(J_x, J_y, J_z)` in kg·m² (eq. 1).
    pub fn inertia(&self) -> DVec3 {
        self.inertia
    }

    /// The largest semi-axis, the body's length scale L (m).
    pub fn length_scale(&self) -> f64 {
        self.semi_axes.max_element()
    }

    /// True when all three semi-axes are equal: the lever arm is then exactly
    /// zero and an impact never changes ω.
    pub fn is_sphere(&self) -> bool {
        self.semi_axes.x == self.semi_axes.y && self.semi_axes.y == self.semi_axes.z
    }
}

/// Position and orientation of the body: `X = centre + rotation · x`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Body → world rotation `A`.
    pub rotation: DMat3,
    /// Centre `X0` in the world frame (m).
    pub centre: DVec3,
}

/// Velocities: centre velocity in the world frame (m/s), angular velocity in
/// the body frame (rad/s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct State {
    pub velocity: DVec3,
    pub omega: DVec3,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inertia_follows_eq1_not_the_papers_printed_values() {
        // physics.md: the paper prints (200, 200, 100) for a=b=1, c=2, m=500;
        // eq. 1 gives (500, 500, 200).
        let e = Ellipsoid::new([1.0, 1.0, 2.0], 500.0).unwrap();
        assert_eq!(e.inertia(), DVec3::new(500.0, 500.0, 200.0));
    }

    #[test]
    fn rejects_bad_values_including_nan() {
        assert!(matches!(
            Ellipsoid::new([1.0, 0.0, 1.0], 1.0),
            Err(BodyError::SemiAxis { index: 1, .. })
        ));
        assert!(Ellipsoid::new([1.0, 1.0, f64::NAN], 1.0).is_err());
        assert!(Ellipsoid::new([1.0, 1.0, 1.0], -1.0).is_err());
        assert!(Ellipsoid::new([1.0, 1.0, 1.0], f64::NAN).is_err());
        assert!(Ellipsoid::new([1.0, 1.0, f64::INFINITY], 1.0).is_err());
    }
}
