//! Drops in lanes: a wavefront of walks. A block of [`BLOCK`] lanes each
//! holds one walk (a sample under one law). Every lane's time-of-impact
//! search advances a few steps at a time in lanes ([`advance`]); a lane
//! whose search is done is harvested at once: its impact joins the others
//! found in the same round, grouped by the set of planes it touches and by
//! law, and solved by the contact kernel in full vectors; then the lane
//! flies on, or takes the next waiting walk if its walk is over (stream
//! compaction, as in wavefront path tracers: Laine, Karras & Aila,
//! "Megakernels Considered Harmful", HPG 2013). Lanes never wait for the
//! slowest lane of the block.
//!
//! What goes to the f64 reference, and is counted: flights that are not
//! closed-form in lanes (an axisymmetric body, a steady or near-separatrix
//! spin, RK4 asked for), searches that spend their step budget, impacts
//! the kernel flags (its own fallback rules), that touch more than three
//! planes or penetrate one, and in f32 a walk from its first touch without
//! approach on (the flight flown again from its start: [`Wave`]'s
//! `coarse`).
//!
//! Which lane a walk lands in never changes its result: its flights and
//! impacts depend only on its own state, and it is recorded in its own log
//! ([`super::walk`]), replayed in sample order.

// Lane code indexes SoA arrays by lane on purpose: the index form is what
// the loop vectoriser sees through.
#![allow(clippy::needless_range_loop)]

use glam::{DMat3, DQuat, DVec3};

use crate::kernel::flight::setup::{setup, Setup, SetupConsts, SetupIn, SetupWork};
use crate::kernel::flight::{advance, FlightLanes, Poses, Times};
use crate::kernel::{
    frame, friction_impulses, geometry, impulses, post, Consts, ContactRecord, Frame, Geometry,
    LawOut, Status, Sweep,
};
use crate::lanes::dispatch::{multiversioned, BLOCK};
use crate::lanes::Real;
use crate::physics::{
    kinetic_energy, solve_impact, ContactGeometry, Flags, Law, Motion, Plane, Pose, Rotation, State,
};
use crate::sampler::Inputs;
use crate::stats::drops::Ending;

use super::ctx::DropCtx;
use super::flight::{start_of, Flight};
use super::walk::{How, Log, Walk};
use crate::kernel::Strike;

/// Search steps between harvests of the done lanes.
const STEPS: u32 = 4;
/// Steps a lane's search may take before the reference flies it.
const BUDGET: u32 = 2_000;

/// The contact kernel of one set of planes, with its scratch space.
struct SetKernel<T, const K: usize> {
    /// The set's planes, in scene order.
    planes: [usize; K],
    consts: Consts<T, K>,
    frictional: bool,
    inputs: Box<Inputs<T>>,
    geo: Box<Geometry<T, K>>,
    out: Box<LawOut<T, K>>,
    frame: Box<Frame<T, K>>,
    sweep: Box<Sweep<T, K>>,
}

/// A kernel for one to three planes.
enum Kernel<T> {
    One(Box<SetKernel<T, 1>>),
    Two(Box<SetKernel<T, 2>>),
    Three(Box<SetKernel<T, 3>>),
}

/// A walk in a lane.
struct Lane {
    /// Its log (index into the chunk's logs) and law (index into the
    /// scene's laws).
    item: usize,
    law: usize,
    walk: Walk,
    /// Its flights are flown by the reference from now on (a coarse
    /// lane's touch without approach: the walk rocks within the lanes'
    /// floor).
    by_reference: bool,
}

/// A lane's impact waiting for the kernel.
struct Pending {
    lane: usize,
    /// The law the impact is solved by (`newton` for `stronge` on several
    /// planes, with `coupled_fallback`).
    law: Law,
    coupled_fallback: bool,
    /// The planes that touch (bit i: plane i).
    mask: usize,
    /// Time from the flight's start, and the motion at the impact (f64).
    time: f64,
    motion: Motion,
}

/// Where solved impacts go: each lane's walk moves on (or ends).
struct Moves<'a> {
    lanes: &'a mut [Option<Lane>],
    logs: &'a mut [Log],
    floor: f64,
    /// Planes within this distance take part ([`Wave::contact_tolerance`]).
    tolerance: f64,
    /// Touches without approach are flown again by the reference
    /// ([`Wave::coarse`]).
    coarse: bool,
    /// The lanes whose flight the reference flies again.
    refly: &'a mut Vec<usize>,
}

impl Moves<'_> {
    /// Lane `p.lane`'s impact is `strike` (`None`: the reference could not
    /// solve it), by the reference or not.
    fn apply(&mut self, p: &Pending, strike: Option<&Strike>, by_reference: bool) {
        let lane = self.lanes[p.lane].as_mut().expect("live lane");
        if self.coarse && strike.is_some_and(|s| s.mask() == 0) {
            // The walk stays at its flight's start.
            self.refly.push(p.lane);
            return;
        }
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

/// A worker's wavefront: the lanes, their flights and searches, and the
/// kernels of the plane sets met so far.
pub(crate) struct Wave<T, const N: usize> {
    flights: Box<FlightLanes<T, N>>,
    times: Box<Times<T>>,
    poses: Box<Poses<T>>,
    kernels: Vec<Option<Kernel<T>>>,
    lanes: Vec<Option<Lane>>,
    /// The flights' torque-free constants, computed in f64 lanes.
    setup_consts: SetupConsts,
    setup_in: Box<SetupIn>,
    setup_work: Box<SetupWork>,
    setup: Box<Setup>,
    pending: Vec<Pending>,
    refly: Vec<usize>,
    /// Planes within this distance at an impact take part (the scene's
    /// contact tolerance, or the lanes' search tolerance if larger).
    contact_tolerance: f64,
    /// Flights in lanes (false: every flight by the reference).
    closed_form: bool,
    /// The lanes' search stops farther from contact than the scene's
    /// `toi_tolerance` (f32). A touch without approach is then an early
    /// stop within the lanes' floor (a rocking body whose contact point
    /// approaches only nearer the plane), so the reference flies that
    /// flight again from its start.
    coarse: bool,
}

impl<T: Real, const N: usize> Wave<T, N> {
    pub(crate) fn new(ctx: &DropCtx) -> Self {
        let scene = ctx.scene;
        let fx = scene.effects();
        let planes: Vec<Plane> = scene.planes().iter().map(|p| p.plane).collect();
        let gravity = DVec3::new(0.0, 0.0, -fx.gravity);
        let flights =
            FlightLanes::new(scene.body(), &planes, gravity, fx.toi_tolerance, fx.horizon);
        Self {
            contact_tolerance: ctx.flight.contact_tolerance.max(flights.tolerance()),
            coarse: flights.tolerance() > fx.toi_tolerance,
            flights,
            times: Times::new(),
            poses: Poses::new(),
            kernels: (0..1 << N).map(|_| None).collect(),
            lanes: (0..BLOCK).map(|_| None).collect(),
            setup_consts: SetupConsts::new(scene.body().inertia()),
            setup_in: SetupIn::new(),
            setup_work: SetupWork::new(),
            setup: Setup::new(),
            pending: Vec::with_capacity(BLOCK),
            refly: Vec::with_capacity(BLOCK),
            closed_form: Flight::rotation_of(scene) == Rotation::Elliptic,
        }
    }
}

impl DropCtx<'_> {
    /// The walks of samples `first..` (one per log, sample-major, then by
    /// law) into `logs`, in lanes of `T`.
    pub(crate) fn walks_in_lanes<T: Real, const N: usize>(
        &self,
        first: u64,
        logs: &mut [Log],
        w: &mut Wave<T, N>,
    ) {
        let laws = self.scene.laws().len();
        let mut next = 0usize;
        let mut take = |logs: &mut [Log]| -> Option<Lane> {
            (next < logs.len()).then(|| {
                let item = next;
                next += 1;
                logs[item].clear();
                let i = first + (item / laws) as u64;
                let start = start_of(&self.start, &self.sampler, i);
                Lane {
                    item,
                    law: item % laws,
                    walk: Walk::new(start),
                    by_reference: false,
                }
            })
        };
        let mut queue: Vec<(usize, Option<Lane>)> = Vec::with_capacity(BLOCK);
        for s in 0..BLOCK {
            queue.push((s, take(logs)));
        }
        self.launch(&mut queue, logs, w, &mut take);
        loop {
            let open = advance(&w.flights, STEPS, BUDGET, &mut w.poses, &mut w.times);
            w.pending.clear();
            let mut harvested = 0;
            for s in 0..BLOCK {
                let Some(lane) = w.lanes[s].as_mut() else {
                    continue;
                };
                if !w.times.done[s] {
                    continue;
                }
                harvested += 1;
                if w.times.hit[s] {
                    let p = self.pending_of(s, lane, w.contact_tolerance, &w.times, &w.poses);
                    w.pending.push(p);
                } else if w.times.stuck[s] {
                    // The reference flies it from the flight's start.
                    logs[lane.item].reference_flights += 1;
                    let law = self.scene.laws()[lane.law];
                    if let Some(e) =
                        self.reference_flight(law, &mut lane.walk, &mut logs[lane.item])
                    {
                        lane.walk.finish(e, &mut logs[lane.item]);
                        w.lanes[s] = None;
                    }
                } else {
                    lane.walk.finish(Ending::FlewAway, &mut logs[lane.item]);
                    w.lanes[s] = None;
                }
            }
            if harvested == 0 && open > 0 {
                continue;
            }
            self.solve_pending(logs, w);
            for s in 0..BLOCK {
                if !w.times.done[s] {
                    continue;
                }
                let lane = match w.lanes[s].take() {
                    Some(lane) => Some(lane),
                    None => take(logs),
                };
                queue.push((s, lane));
            }
            self.launch(&mut queue, logs, w, &mut take);
            if w.lanes.iter().all(Option::is_none) {
                break;
            }
        }
    }

    /// Each lane `s` of `queue` takes its walk (or idles if none): the
    /// walk's next flight begins in lanes, after any flights the reference
    /// flies and walks that end (each replaced by the next waiting walk
    /// from `take`). The flights' torque-free constants are computed
    /// together, in lanes.
    fn launch<T: Real, const N: usize>(
        &self,
        queue: &mut Vec<(usize, Option<Lane>)>,
        logs: &mut [Log],
        w: &mut Wave<T, N>,
        take: &mut impl FnMut(&mut [Log]) -> Option<Lane>,
    ) {
        let bounces = self.scene.effects().bounces as usize;
        let mut ready: Vec<(usize, Lane)> = Vec::with_capacity(BLOCK);
        while !queue.is_empty() {
            // Each walk on to its next flight, or ended and replaced.
            for (s, mut lane) in queue.drain(..) {
                while let Some(mut l) = lane.take() {
                    match l.walk.fly(bounces) {
                        None if w.closed_form && !l.by_reference => ready.push((s, l)),
                        None => {
                            let log = &mut logs[l.item];
                            log.reference_flights += 1;
                            let law = self.scene.laws()[l.law];
                            match self.reference_flight(law, &mut l.walk, log) {
                                Some(e) => {
                                    l.walk.finish(e, log);
                                    lane = take(logs);
                                }
                                None => lane = Some(l),
                            }
                        }
                        Some(e) => {
                            l.walk.finish(e, &mut logs[l.item]);
                            lane = take(logs);
                        }
                    }
                }
                if ready.last().is_none_or(|(r, _)| *r != s) {
                    w.lanes[s] = None;
                    w.times.idle(s);
                }
            }
            if ready.is_empty() {
                break;
            }
            // The flights' constants in lanes, then each flight begins (or,
            // if not closed-form, the reference flies it).
            for (j, (_, l)) in ready.iter().enumerate() {
                let r = l.walk.motion.rotation.transpose().to_cols_array();
                for k in 0..9 {
                    w.setup_in.rotation[k][j] = r[k];
                }
                for k in 0..3 {
                    w.setup_in.omega[k][j] = l.walk.motion.omega[k];
                }
            }
            let n = ready.len();
            setup(
                &w.setup_consts,
                &w.setup_in,
                n,
                &mut w.setup_work,
                &mut w.setup,
            );
            for (j, (s, mut l)) in ready.drain(..).enumerate() {
                let body = self.scene.body();
                if w.flights.set_prepared(s, body, &l.walk.motion, &w.setup, j) {
                    w.times.begin(&w.flights, s);
                    w.lanes[s] = Some(l);
                    continue;
                }
                let log = &mut logs[l.item];
                log.reference_flights += 1;
                let law = self.scene.laws()[l.law];
                let next = match self.reference_flight(law, &mut l.walk, log) {
                    Some(e) => {
                        l.walk.finish(e, log);
                        take(logs)
                    }
                    None => Some(l),
                };
                queue.push((s, next));
            }
        }
    }

    /// Lane `s`'s impact: the motion at it in f64 (the centre's parabola
    /// from the flight's start, the attitude and spin from the lanes), the
    /// planes that touch and the law that solves it.
    fn pending_of<T: Real>(
        &self,
        s: usize,
        lane: &Lane,
        contact_tolerance: f64,
        times: &Times<T>,
        poses: &Poses<T>,
    ) -> Pending {
        let t = times.time[s].to_f64();
        let m0 = &lane.walk.motion;
        let (rotation, omega) = poses.lane(s);
        // The lanes' attitude, made orthonormal to the reference's rounding.
        let q = DQuat::from_mat3(&rotation).normalize();
        let gravity = self.flight.gravity;
        let motion = Motion {
            centre: m0.centre + m0.velocity * t + gravity * (0.5 * t * t),
            rotation: DMat3::from_quat(q),
            velocity: m0.velocity + gravity * t,
            omega,
        };
        let body = self.scene.body();
        let mut mask = 0;
        let mut penetrating = false;
        let semi = body.semi_axes();
        for (i, p) in self.flight.planes.iter().enumerate() {
            let u = motion.rotation.transpose() * p.normal();
            let d = p.signed_distance(motion.centre) - (semi * u).length();
            mask |= ((d.abs() <= contact_tolerance) as usize) << i;
            penetrating |= d < -contact_tolerance;
        }
        let law = self.scene.laws()[lane.law];
        let several = mask.count_ones() > 1;
        let (law, coupled_fallback) = match law {
            Law::Stronge if several => (Law::Newton, true),
            law => (law, false),
        };
        Pending {
            lane: s,
            law,
            coupled_fallback,
            // Four or more planes, or one penetrated: the reference decides.
            mask: if mask.count_ones() > 3 || penetrating {
                usize::MAX
            } else {
                mask
            },
            time: t,
            motion,
        }
    }

    /// Solves the waiting impacts, grouped by plane set and law, each
    /// group in full vectors of the kernel, and moves each walk on.
    fn solve_pending<T: Real, const N: usize>(&self, logs: &mut [Log], w: &mut Wave<T, N>) {
        let laws = self.scene.laws();
        let law_key = |l: Law| laws.iter().position(|&x| x == l).unwrap_or(laws.len());
        let Wave {
            pending,
            kernels,
            lanes,
            refly,
            coarse,
            contact_tolerance,
            ..
        } = w;
        pending.sort_unstable_by_key(|p| (p.mask, law_key(p.law), p.lane));
        let mut out = Moves {
            lanes,
            logs,
            floor: self.scene.effects().energy_floor,
            tolerance: *contact_tolerance,
            coarse: *coarse,
            refly,
        };
        for group in pending.chunk_by(|a, b| a.mask == b.mask && a.law == b.law) {
            let mask = group[0].mask;
            if mask == usize::MAX {
                for p in group {
                    out.apply(p, self.reference_strike(p, out.tolerance).as_ref(), true);
                }
                continue;
            }
            if mask == 0 {
                // Nothing within the tolerance (rounding): no impulse.
                for p in group {
                    out.apply(p, Some(&self.untouched(&p.motion)), false);
                }
                continue;
            }
            let kernel = kernels[mask].get_or_insert_with(|| self.kernel_of(mask));
            match kernel {
                Kernel::One(k) => self.solve_group(k, group, &mut out),
                Kernel::Two(k) => self.solve_group(k, group, &mut out),
                Kernel::Three(k) => self.solve_group(k, group, &mut out),
            }
        }
        pending.clear();
        for s in refly.drain(..) {
            let lane = lanes[s].as_mut().expect("live lane");
            lane.by_reference = true;
            let log = &mut logs[lane.item];
            log.reference_flights += 1;
            let law = self.scene.laws()[lane.law];
            if let Some(e) = self.reference_flight(law, &mut lane.walk, log) {
                lane.walk.finish(e, log);
                lanes[s] = None;
            }
        }
    }

    /// The kernel of the planes in `mask` (one to three).
    fn kernel_of<T: Real>(&self, mask: usize) -> Kernel<T> {
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
    fn solve_group<T: Real, const K: usize>(
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
    fn untouched(&self, m: &Motion) -> Strike {
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
    fn reference_strike(&self, p: &Pending, tolerance: f64) -> Option<Strike> {
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
