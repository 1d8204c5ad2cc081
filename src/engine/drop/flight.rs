//! What every flight of a drop run shares, and where each sample starts.

use glam::DVec3;

use crate::config::{DropBox, Scene};
use crate::physics::{
    solve_impact, time_of_impact, Ellipsoid, Impact, ImpactError, ImpactOutcome, Law, Motion,
    Plane, Pose, Rotation, State,
};
use crate::sampler::Sampler;

/// The start of sample `i`: drawn orientation and velocities, centre
/// uniform in the drop box (draws 9–11, [`Sampler::start_uniforms`]).
pub fn start_of(start: &DropBox, sampler: &Sampler, i: u64) -> Motion {
    let (a, v, w) = sampler.reference(i);
    let (lo, hi) = (start.low, start.high);
    let u = DVec3::from_array(sampler.start_uniforms(i));
    Motion {
        centre: lo + (hi - lo) * u,
        rotation: a,
        velocity: v,
        omega: w,
    }
}

/// What every flight of a run shares, built once per run (not per sample).
pub struct Flight {
    pub(super) planes: Vec<Plane>,
    pub(super) gravity: DVec3,
    pub(super) rotation: Rotation,
    pub(super) toi_tolerance: f64,
    pub(super) horizon: f64,
    /// Planes within this distance at the impact take part.
    pub(super) contact_tolerance: f64,
}

/// Why a flight ended without a solved impact.
pub(super) enum Stop {
    FlewAway,
    Unsolved,
}

impl Flight {
    /// The scene's flight with the given rotation and time-of-impact
    /// tolerance (a tolerance above the scene's contact tolerance widens it).
    pub fn new(scene: &Scene, rotation: Rotation, toi_tolerance: f64) -> Self {
        let fx = scene.effects();
        Self {
            planes: scene.planes().iter().map(|p| p.plane).collect(),
            gravity: DVec3::new(0.0, 0.0, -fx.gravity),
            rotation,
            toi_tolerance,
            horizon: fx.horizon,
            contact_tolerance: scene.tolerance().max(toi_tolerance),
        }
    }

    /// The scene's own rotation in flight (`effects.flight_rotation`).
    pub fn rotation_of(scene: &Scene) -> Rotation {
        let fx = scene.effects();
        if fx.flight_rotation == "rk4" {
            Rotation::Rk4 {
                max_step: fx.flight_step,
            }
        } else {
            Rotation::exact_for(scene.body())
        }
    }

    /// Flies from `m` to the next impact and solves it under `law`. An
    /// impact that touches several planes at once under `stronge` (defined
    /// for one contact) is solved by `newton` (friction.md), and the third
    /// value says so (`coupled_fallback`).
    pub(super) fn next(
        &self,
        body: &Ellipsoid,
        m: &Motion,
        law: Law,
    ) -> Result<(Impact, ImpactOutcome, bool), Stop> {
        let hit = time_of_impact(
            body,
            m,
            &self.planes,
            self.gravity,
            self.rotation,
            self.toi_tolerance,
            self.horizon,
        )
        .ok_or(Stop::FlewAway)?;
        let pose = Pose {
            rotation: hit.motion.rotation,
            centre: hit.motion.centre,
        };
        let state = State {
            velocity: hit.motion.velocity,
            omega: hit.motion.omega,
        };
        let solve =
            |law| solve_impact(body, pose, state, &self.planes, law, self.contact_tolerance);
        match solve(law) {
            Ok(o) => Ok((hit, o, false)),
            Err(ImpactError::StrongeSeveral(_)) => solve(Law::Newton)
                .map(|o| (hit, o, true))
                .map_err(|_| Stop::Unsolved),
            Err(_) => Err(Stop::Unsolved),
        }
    }
}
