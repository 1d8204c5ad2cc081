//! A drop run's context, built once per run, and one law's first impacts
//! of a block as the block statistics take them.

use super::flight::Flight;
use crate::config::{DropBox, Scene};
use crate::kernel::{LawOut, Status, Strike};
use crate::lanes::dispatch::BLOCK;
use crate::physics::{Ellipsoid, State};
use crate::sampler::Sampler;
use crate::stats::block::StatsPlan;

/// What a drop batch needs, built once per run.
pub struct DropCtx<'a> {
    pub(super) scene: &'a Scene,
    pub(super) start: DropBox,
    pub(super) sampler: Sampler,
    pub(super) flight: Flight,
    pub(super) plan: StatsPlan,
    /// Walks by the f64 reference alone (else in lanes of the scene's
    /// precision).
    pub(super) reference: bool,
    /// The workers' lanes (a `Box<Lanes<N>>` each), kept from batch to
    /// batch.
    pub(super) lanes: crate::engine::pool::Pool<Box<dyn std::any::Any + Send>>,
}

/// One law's first impacts of a block, in lanes, for the block statistics:
/// the state before (the impact's own, per law) and the results.
pub(crate) struct Firsts<'a, const N: usize> {
    pub(super) energy: &'a mut [f64; BLOCK],
    pub(super) vn: &'a mut [[f64; BLOCK]; N],
    pub(super) out: &'a mut LawOut<f64, N>,
}

impl<const N: usize> Firsts<'_, N> {
    /// Lane `s`: no impact (`status` 0, or Status::UNSOLVED), its values unread.
    pub(super) fn none(&mut self, s: usize, status: Status) {
        self.out.status[s] = status;
    }

    /// Lane `s`: the impact `o` of a body that came in with `before`.
    pub(super) fn impact(
        &mut self,
        s: usize,
        body: &Ellipsoid,
        before: &State,
        o: &Strike,
        status: Status,
    ) {
        self.energy[s] = o.energy_before;
        for i in 0..N {
            self.vn[i][s] = o.normal_velocity_before[i];
        }
        o.write(before, body, self.out, s, status);
    }
}

/// A worker's lanes, in the scene's precision.
impl<'a> DropCtx<'a> {
    pub fn new(scene: &'a Scene, start: DropBox, keep: crate::config::Keep) -> Self {
        let fx = scene.effects();
        Self {
            scene,
            start,
            sampler: Sampler::new(scene),
            flight: Flight::new(scene, Flight::rotation_of(scene), fx.toi_tolerance),
            // |ω⁺| changes in flight and at impacts: computed per sample.
            plan: StatsPlan::of(scene, keep).per_sample_spin(),
            reference: false,
            lanes: crate::engine::pool::Pool::new(),
        }
    }

    /// The same runs with every flight and impact by the f64 reference, one
    /// walk after the other (what the lanes are tested against).
    pub fn by_reference(self) -> Self {
        Self {
            reference: true,
            ..self
        }
    }
}
