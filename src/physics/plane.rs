//! Planes `n·X + e = 0` with the unit normal pointing into the free side
//! (physics.md, "Planes and the contact point").

use glam::DVec3;

/// Most planes of a drop scene (2^planes sets of planes hit per bounce),
/// and so most contacts an impact of the reference solves on the stack.
pub const MAX_DROP_PLANES: usize = 6;

/// Why a plane could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PlaneError {
    #[error("normal must be a finite non-zero vector, got [{}, {}, {}]", .0[0], .0[1], .0[2])]
    Normal([f64; 3]),
    #[error("offset must be finite, got {0}")]
    Offset(f64),
    #[error("restitution must be in [0, 1], got {0}")]
    Restitution(f64),
    #[error("friction must be a finite number ≥ 0, got {0}")]
    Friction(f64),
}

impl PlaneError {
    /// The input field at fault: `normal`, `offset`, `restitution` or
    /// `friction`.
    pub fn field(&self) -> &'static str {
        match self {
            PlaneError::Normal(_) => "normal",
            PlaneError::Offset(_) => "offset",
            PlaneError::Restitution(_) => "restitution",
            PlaneError::Friction(_) => "friction",
        }
    }
}

/// A validated plane: unit normal `n`, offset `e` (m), coefficient of
/// restitution `k ∈ [0, 1]` and Coulomb coefficient `μ ≥ 0` (0 unless set
/// with [`Plane::with_friction`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    normal: DVec3,
    offset: f64,
    restitution: f64,
    friction: f64,
}

impl Plane {
    /// Builds `αX + βY + γZ + δ = 0` from any non-zero normal `(α, β, γ)`;
    /// the normal and the offset are both divided by `|(α, β, γ)|`, so the
    /// plane is the same one.
    pub fn new(normal: [f64; 3], offset: f64, restitution: f64) -> Result<Self, PlaneError> {
        let raw = DVec3::from_array(normal);
        if !raw.is_finite() {
            return Err(PlaneError::Normal(normal));
        }
        // Scale before taking the length so that tiny or huge normals neither
        // underflow nor overflow.
        let scale = raw.abs().max_element();
        if !(scale > 0.0) {
            return Err(PlaneError::Normal(normal));
        }
        let scaled = raw / scale;
        let len = scaled.length();
        if !offset.is_finite() {
            return Err(PlaneError::Offset(offset));
        }
        if !(0.0..=1.0).contains(&restitution) {
            return Err(PlaneError::Restitution(restitution));
        }
        Ok(Self {
            normal: scaled / len,
            offset: offset / scale / len,
            restitution,
            friction: 0.0,
        })
    }

    /// The same plane with Coulomb coefficient `mu` (finite, ≥ 0).
    pub fn with_friction(self, mu: f64) -> Result<Self, PlaneError> {
        if !(mu.is_finite() && mu >= 0.0) {
            return Err(PlaneError::Friction(mu));
        }
        Ok(Self {
            friction: mu,
            ..self
        })
    }

    /// Coulomb coefficient `μ`.
    pub fn friction(&self) -> f64 {
        self.friction
    }

    /// Unit normal, pointing into the free half-space.
    pub fn normal(&self) -> DVec3 {
        self.normal
    }

    /// Offset `e` in metres for the unit normal.
    pub fn offset(&self) -> f64 {
        self.offset
    }

    /// Coefficient of restitution `k`.
    pub fn restitution(&self) -> f64 {
        self.restitution
    }

    /// Signed distance of a world point from the plane (m), positive on the
    /// free side.
    pub fn signed_distance(&self, point: DVec3) -> f64 {
        self.normal.dot(point) + self.offset
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normalises_normal_and_offset_together() {
        let p = Plane::new([0.0, 0.0, 2.0], -4.0, 0.5).unwrap();
        assert_eq!(p.normal(), DVec3::Z);
        assert_eq!(p.offset(), -2.0);
        let tiny = Plane::new([1e-300, 0.0, 0.0], 0.0, 0.5).unwrap();
        assert_eq!(tiny.normal(), DVec3::X);
    }

    #[test]
    fn rejects_zero_normal_nan_and_bad_restitution() {
        assert!(matches!(
            Plane::new([0.0, 0.0, 0.0], 0.0, 0.5),
            Err(PlaneError::Normal(_))
        ));
        assert!(Plane::new([f64::NAN, 0.0, 1.0], 0.0, 0.5).is_err());
        assert!(Plane::new([0.0, 0.0, 1.0], f64::NAN, 0.5).is_err());
        assert!(Plane::new([0.0, 0.0, 1.0], 0.0, 1.5).is_err());
        assert!(Plane::new([0.0, 0.0, 1.0], 0.0, f64::NAN).is_err());
        assert!(Plane::new([0.0, 0.0, 1.0], 0.0, -0.0).is_ok());
    }
}
