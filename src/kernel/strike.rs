//! One impact of a drop as it is recorded: per plane its distance, normal
//! velocities, impulse and friction, and the state and energy after. The
//! reference's [`ImpactOutcome`] and the lane kernel's results both become
//! a [`Strike`], so the bounce statistics, the first impact's lane and the
//! per-impact rows are written alike whichever solved it.

use super::{write_record, ContactRecord, LawOut};
use crate::kernel::Status;
use crate::lanes::Real;
use crate::physics::MAX_DROP_PLANES;
use crate::physics::{Ellipsoid, Flags, ImpactOutcome, State};

/// One impact, every plane of the scene in scene order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Strike {
    /// The scene's planes (the first `planes` entries below are used).
    pub planes: usize,
    pub contacts: [ContactRecord; MAX_DROP_PLANES],
    /// Signed distance of each plane at the impact (m).
    pub distance: [f64; MAX_DROP_PLANES],
    /// Normal velocity of each plane's support point before the impact.
    pub normal_velocity_before: [f64; MAX_DROP_PLANES],
    pub after: State,
    pub energy_before: f64,
    pub energy_after: f64,
    pub flags: Flags,
}

impl Strike {
    /// The reference's outcome, with the planes' distances at the impact.
    pub fn of(o: &ImpactOutcome, distances: &[f64]) -> Self {
        let planes = o.contacts.len();
        assert!(planes <= MAX_DROP_PLANES, "{planes} planes in a drop");
        let mut contacts = [ContactRecord::default(); MAX_DROP_PLANES];
        let mut distance = [0.0; MAX_DROP_PLANES];
        let mut before = [0.0; MAX_DROP_PLANES];
        for (i, c) in o.contacts.iter().enumerate() {
            contacts[i] = ContactRecord::from(c);
            distance[i] = distances[i];
            before[i] = c.normal_velocity_before;
        }
        Self {
            planes,
            contacts,
            distance,
            normal_velocity_before: before,
            after: o.after,
            energy_before: o.energy_before,
            energy_after: o.energy_after,
            flags: o.flags,
        }
    }

    /// The planes that took an impulse (bit i: plane i).
    pub fn mask(&self) -> usize {
        self.contacts[..self.planes]
            .iter()
            .enumerate()
            .filter(|(_, c)| c.impulse > 0.0)
            .fold(0, |m, (i, _)| m | 1 << i)
    }

    /// The planes' distances at the impact.
    pub fn distances(&self) -> &[f64] {
        &self.distance[..self.planes]
    }

    /// Writes the impact into lane `s` of `out` (every plane a recorded
    /// contact, in scene order) for the block statistics.
    pub fn write<T: Real, const N: usize>(
        &self,
        before: &State,
        body: &Ellipsoid,
        out: &mut LawOut<T, N>,
        s: usize,
        status: Status,
    ) {
        let after = (&self.after, self.energy_after, self.flags);
        let contacts = self.contacts[..self.planes].iter().copied();
        write_record(after, contacts, before, body, out, s, status);
    }
}
