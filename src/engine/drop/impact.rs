//! A round's impacts: the lanes whose search is done wait as [`Pending`]
//! impacts; grouped by plane set and law, each group is solved by the
//! contact kernel of its planes ([`SetKernel`]) in full vectors, flagged
//! lanes by the f64 reference, and each walk moves on ([`Moves`]).

// Lane code indexes SoA arrays by lane on purpose: the index form is what
// the loop vectoriser sees through.
#![allow(clippy::needless_range_loop)]

use glam::DVec3;

use crate::kernel::{
    frame, friction_impulses, geometry, impulses, post, Consts, ContactRecord, Frame, Geometry,
    LawOut, Status, Strike, Sweep,
};
use crate::lanes::dispatch::{multiversioned, BLOCK};
use crate::lanes::Real;
use crate::physics::{
    kinetic_energy, solve_impact, ContactGeometry, Flags, Law, Motion, Pose, State,
};
use crate::sampler::Inputs;

use super::ctx::DropCtx;
use super::walk::{How, Log, Walk};

/// The contact kernel of one set of planes, with its scratch space.
pub(super) struct SetKernel<T, const K: usize> {
    /// The set's planes, in scene order.
    pub(super) planes: [usize; K],
    pub(super) consts: Consts<T, K>,
    pub(super) frictional: bool,
    pub(super) inputs: Box<Inputs<T>>,
    pub(super) geo: Box<Geometry<T, K>>,
    pub(super) out: Box<LawOut<T, K>>,
    pub(super) frame: Box<Frame<T, K>>,
    pub(super) sweep: Box<Sweep<T, K>>,
}

/// A kernel for one to three planes.
pub(super) enum Kernel<T> {
    One(Box<SetKernel<T, 1>>),
    Two(Box<SetKernel<T, 2>>),
    Three(Box<SetKernel<T, 3>>),
}

/// A walk in a lane.
pub(super) struct Lane {
    /// Its log (index into the chunk's logs) and law (index into the
    /// scene's laws).
    pub(super) item: usize,
    pub(super) law: usize,
    pub(super) walk: Walk,
    /// Its flights are flown by the reference from now on (an f32 impact
    /// that could not be located at contact: the walk rocks or grazes
    /// within the lanes' floor).
    pub(super) by_reference: bool,
}

/// A lane's impact waiting for the kernel.
pub(super) struct Pending {
    pub(super) lane: usize,
    /// The law the impact is solved by (`newton` for `stronge` on several
    /// planes, with `coupled_fallback`).
    pub(super) law: Law,
    pub(super) coupled_fallback: bool,
    /// The planes that touch (bit i: plane i).
    pub(super) mask: usize,
    /// Time from the flight's start, and the motion at the impact (f64).
    pub(super) time: f64,
    pub(super) motion: Motion,
}

/// Where solved impacts go: each lane's walk moves on (or ends).
pub(super) struct Moves<'a> {
    pub(super) lanes: &'a mut [Option<Lane>],
    pub(super) logs: &'a mut [Log],
    pub(super) floor: f64,
    /// Planes within this distance take part ([`Wave::contact_tolerance`]).
    pub(super) tolerance: f64,
}

impl Moves<'_> {
    /// Lane `p.lane`'s impact is `strike` (`None`: the reference could not
    /// solve it), by the reference or not.
    pub(super) fn apply(&mut self, p: &Pending, strike: Option<&Strike>, by_reference: bool) {
        let lane = self.lanes[p.lane].as_mut().expect("live lane");
        let log = &mut self.logs[lane.item];
        log.reference_impacts += by_reference as u32;
        let how = How {
            coupled_fallback: p.coupled_fallback,
            recomputed: by_reference,
        };
        let ending = match strike {
            Some(strike) => lane
                .walk
                .struck(p.time, p.motion, strike, how, self.floor, log),
            None => Some(lane.walk.unsolved(log)),
        };
        if let Some(e) = ending {
            lane.walk.finish(e, log);
            self.lanes[p.lane] = None;
        }
    }
}

impl DropCtx<'_> {
    /// The kernel of the planes in `mask` (one to three).
    pub(super) fn kernel_of<T: Real>(&self, mask: usize) -> Kernel<T> {
        let planes: Vec<usize> = (0..self.scene.planes().len())
            .filter(|&i| mask >> i & 1 == 1)
            .collect();
        let view = self.scene.contact_view(&planes);
        match planes.len() {
            1 => Kernel::One(SetKernel::new(&view, &planes)),
            2 => Kernel::Two(SetKernel::new(&view, &planes)),
            _ => Kernel::Three(SetKernel::new(&view, &planes)),
        }
    }

    /// One group's impacts (one plane set, one law, at most a block) in
    /// the kernel; flagged lanes by the reference.
    pub(super) fn solve_group<T: Real, const K: usize>(
        &self,
        k: &mut SetKernel<T, K>,
        group: &[Pending],
        out: &mut Moves,
    ) {
        for chunk in group.chunks(BLOCK) {
            for s in 0..BLOCK {
                // Lanes past the group repeat its first impact.
                let m = &chunk[if s < chunk.len() { s } else { 0 }].motion;
                let a = m.rotation.transpose().to_cols_array();
                for r in 0..9 {
                    k.inputs.a[r][s] = T::from_f64(a[r]);
                }
                for d in 0..3 {
                    k.inputs.v[d][s] = T::from_f64(m.velocity[d]);
                    k.inputs.w[d][s] = T::from_f64(m.omega[d]);
                }
            }
            let law = chunk[0].law;
            if k.frictional {
                friction_set::<T, K>(&k.consts, &k.inputs, &mut k.frame, &mut k.geo);
                friction_set_law::<T, K>(
                    &k.consts,
                    law,
                    &k.inputs,
                    &k.geo,
                    &mut k.frame,
                    &mut k.sweep,
                    &mut k.out,
                );
            } else {
                frictionless_set::<T, K>(&k.consts, law, &k.inputs, &mut k.geo, &mut k.out);
            }
            for (s, p) in chunk.iter().enumerate() {
                let st = k.out.status[s];
                if st.has(Status::NEEDS_REFERENCE) {
                    out.apply(p, self.reference_strike(p, out.tolerance).as_ref(), true);
                } else {
                    out.apply(p, Some(&self.strike_of(k, s, st, &p.motion)), false);
                }
            }
        }
    }

    /// The kernel's answer in lane `s` as a strike: impulses, friction,
    /// flags and the state after from the lanes; per plane its distance
    /// and normal velocities, and the contact points' sliding, in f64 from
    /// the motion and the state after.
    fn strike_of<T: Real, const K: usize>(
        &self,
        k: &SetKernel<T, K>,
        s: usize,
        st: Status,
        m: &Motion,
    ) -> Strike {
        let after = State {
            velocity: DVec3::from_array(std::array::from_fn(|d| k.out.v_after[d][s].to_f64())),
            omega: DVec3::from_array(std::array::from_fn(|d| k.out.w_after[d][s].to_f64())),
        };
        let mut strike = self.strike_at(m, &after);
        for (j, &i) in k.planes.iter().enumerate() {
            let c = &mut strike.contacts[i];
            c.approaching = st.has(Status::approaching(j));
            c.impulse = k.out.lambda[j][s].to_f64();
            c.tangential = if k.frictional {
                k.out.tangential[j][s].to_f64()
            } else {
                0.0
            };
            // The lanes decided sticking where their precision resolves it
            // (friction.md's threshold is 1e-9 of the velocity scale, below
            // f32's rounding of the state after): a sticking contact's
            // sliding is zero, not the rounding of that state.
            if k.frictional && st.has(Status::sticking(j)) {
                c.sliding_after = 0.0;
            }
        }
        strike.flags = Flags::from_bits(st);
        strike
    }

    /// The strike of an impact no plane takes part in: the state
    /// unchanged.
    pub(super) fn untouched(&self, m: &Motion) -> Strike {
        let state = State {
            velocity: m.velocity,
            omega: m.omega,
        };
        self.strike_at(m, &state)
    }

    /// A strike at `m` with the state `after` and no impulses yet: per
    /// plane its distance, the normal velocities before and after, and the
    /// contact point's sliding after, in f64 (one contact geometry per
    /// plane).
    fn strike_at(&self, m: &Motion, after: &State) -> Strike {
        let body = self.scene.body();
        let mut contacts = [ContactRecord::default(); crate::config::MAX_DROP_PLANES];
        let mut distance = [0.0; crate::config::MAX_DROP_PLANES];
        let mut before = [0.0; crate::config::MAX_DROP_PLANES];
        for (i, p) in self.flight.planes.iter().enumerate() {
            let g = ContactGeometry::new(body, m.rotation, m.centre, p);
            distance[i] = g.distance;
            before[i] = g.normal_velocity(p, m.velocity, m.omega);
            contacts[i].normal_velocity_after = g.normal_velocity(p, after.velocity, after.omega);
            let n = p.normal();
            let point = after.velocity + m.rotation * after.omega.cross(g.body_point);
            contacts[i].sliding_after = (point - n * n.dot(point)).length();
        }
        Strike {
            planes: self.flight.planes.len(),
            contacts,
            distance,
            normal_velocity_before: before,
            after: *after,
            energy_before: kinetic_energy(body, m.velocity, m.omega),
            energy_after: kinetic_energy(body, after.velocity, after.omega),
            flags: Flags::default(),
        }
    }

    /// The impact by the f64 reference at the lanes' motion, with the
    /// planes within `tolerance` taking part, as the lanes take them
    /// (`None`: it cannot be solved).
    pub(super) fn reference_strike(&self, p: &Pending, tolerance: f64) -> Option<Strike> {
        let body = self.scene.body();
        let pose = Pose {
            rotation: p.motion.rotation,
            centre: p.motion.centre,
        };
        let state = State {
            velocity: p.motion.velocity,
            omega: p.motion.omega,
        };
        let planes = &self.flight.planes;
        let o = solve_impact(body, pose, state, planes, p.law, tolerance).ok()?;
        let distances: Vec<f64> = o.contacts.iter().map(|c| c.geometry.distance).collect();
        Some(Strike::of(&o, &distances))
    }
}

impl<T: Real, const K: usize> SetKernel<T, K> {
    fn new(view: &crate::config::Scene, planes: &[usize]) -> Box<Self> {
        Box::new(Self {
            planes: std::array::from_fn(|j| planes[j]),
            consts: Consts::new(view),
            frictional: view.effects().friction,
            inputs: Inputs::new(),
            geo: Geometry::new(),
            out: LawOut::new(),
            frame: Frame::new(),
            sweep: Sweep::new(),
        })
    }
}

multiversioned! {
    /// A block of impacts on one plane set without friction: geometry, one
    /// law's impulses and the state after.
    fn frictionless_set<T: Real, const K: usize>(
        consts: &Consts<T, K>,
        law: Law,
        inputs: &Inputs<T>,
        geo: &mut Geometry<T, K>,
        out: &mut LawOut<T, K>,
    ) {
        crate::lanes::dispatch::align_frame();
        geometry::<T, K, true>(consts, inputs, geo, !matches!(law, Law::Newton));
        impulses::<T, K, true, true>(consts, law, geo, out);
        post::<T, K, true>(consts, inputs, geo, out);
    }
}

multiversioned! {
    /// The contact frames of a block of impacts with friction.
    fn friction_set<T: Real, const K: usize>(
        consts: &Consts<T, K>,
        inputs: &Inputs<T>,
        fr: &mut Frame<T, K>,
        geo: &mut Geometry<T, K>,
    ) {
        crate::lanes::dispatch::align_frame();
        frame::<T, K>(consts, inputs, fr, geo);
    }
}

multiversioned! {
    /// One law on a block of impacts with friction.
    fn friction_set_law<T: Real, const K: usize>(
        consts: &Consts<T, K>,
        law: Law,
        inputs: &Inputs<T>,
        geo: &Geometry<T, K>,
        fr: &mut Frame<T, K>,
        sweep: &mut Sweep<T, K>,
        out: &mut LawOut<T, K>,
    ) {
        crate::lanes::dispatch::align_frame();
        friction_impulses::<T, K>(consts, law, inputs, geo, fr, sweep, out);
    }
}
