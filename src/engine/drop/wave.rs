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
//! planes or penetrate one, and in f32 the flights of impacts with a second
//! plane within what the lanes resolve, and a walk from the first impact
//! that cannot be located at contact on (a touch without approach within
//! the lanes' floor, a graze: the flight flown again from its start,
//! [`Wave`]'s `polish`).
//!
//! f32 lanes stop their search up to 256 ulp of the body short of contact;
//! each impact is then located at contact in f64 from the lanes' state
//! (Newton's method on the signed distance, safeguarded by bisection, with
//! the attitude carried from the lanes' pose by second-order turns), so
//! that the state at the impact and the other planes' distances are those
//! at contact, to what the lanes' attitude resolves.
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
use crate::lanes::dispatch::BLOCK;
use crate::lanes::Real;
use crate::physics::{contact_near, Carried, Law, Motion, Plane, Rotation};
use crate::stats::drops::Ending;

use super::ctx::DropCtx;
use super::flight::Flight;
use super::impact::{Kernel, Lane, Moves, Pending};
use super::walk::Log;

/// Search steps between harvests of the done lanes.
const STEPS: u32 = 4;
/// How far (rad) an f32 impact is located from the lanes' pose, and the
/// second-order turns it is carried by ([`Carried`]: an error of about a
/// sixth of a turn's cube per turn, at most 40 × 2e-8 = 8e-7 rad, below the
/// lanes' own resolution of a distance, 64 ulp of the body).
const MAX_TURN: f64 = 0.2;
const TURN_STEP: f64 = 5e-3;
/// Steps a lane's search may take before the reference flies it.
const BUDGET: u32 = 2_000;

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
    /// Lanes whose flight the reference flies again from its start, and
    /// whether the rest of the walk is the reference's too.
    refly: Vec<(usize, bool)>,
    /// Planes within this distance at an impact take part (the scene's
    /// contact tolerance, in either precision).
    contact_tolerance: f64,
    /// Flights in lanes (false: every flight by the reference).
    closed_form: bool,
    /// The lanes' search stops farther from contact than the scene's
    /// `toi_tolerance` (f32: 256 ulp of the body). Each impact is then
    /// located at contact in f64 from the lanes' state where they stopped
    /// ([`crate::physics::contact_near`]); where it cannot be (a touch
    /// without approach within the lanes' floor, a graze: the rest of the
    /// walk too), or where a second plane is within what the lanes'
    /// attitude resolves (`resolution`), the reference flies that flight
    /// again from its start.
    polish: bool,
    /// How far off the lanes' attitude can put a plane's distance (m):
    /// 64 ulp of the type at the body's largest semi-axis (measured: at
    /// most 16 ulp over drop_corner's and drop_dice's f32 impacts).
    resolution: f64,
}

impl<T: Real, const N: usize> Wave<T, N> {
    pub(crate) fn new(ctx: &DropCtx) -> Self {
        let scene = ctx.scene;
        let fx = scene.effects();
        let planes: Vec<Plane> = scene.planes().iter().map(|p| p.plane).collect();
        let gravity = DVec3::new(0.0, 0.0, -fx.gravity);
        let flights =
            FlightLanes::new(scene.body(), &planes, gravity, fx.toi_tolerance, fx.horizon);
        let polish = flights.tolerance() > fx.toi_tolerance;
        Self {
            // Located in f64, impacts take the reference's planes.
            contact_tolerance: ctx.flight.contact_tolerance,
            polish,
            resolution: 64.0 * T::EPSILON.to_f64() * scene.body().semi_axes().max_element(),
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
                Lane {
                    item,
                    law: item % laws,
                    walk: self.walk_of(i),
                    by_reference: false,
                }
            })
        };
        let mut queue: Vec<usize> = Vec::with_capacity(BLOCK);
        for s in 0..BLOCK {
            w.lanes[s] = take(logs);
            queue.push(s);
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
                let log = &mut logs[lane.item];
                log.lane_flights += 1;
                log.lane_poses += w.times.steps[s] + 1;
                if w.times.hit[s] {
                    let polish = w.polish.then_some(w.resolution);
                    match self.pending_of(s, lane, w.contact_tolerance, &w.times, &w.poses, polish)
                    {
                        Ok(p) => w.pending.push(p),
                        Err(rest) => w.refly.push((s, rest)),
                    }
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
                if w.lanes[s].is_none() {
                    w.lanes[s] = take(logs);
                }
                queue.push(s);
            }
            self.launch(&mut queue, logs, w, &mut take);
            if w.lanes.iter().all(Option::is_none) {
                break;
            }
        }
    }

    /// Each lane `s` of `queue` flies its walk on (or idles if it has
    /// none): the walk's next flight begins in lanes, after any flights the
    /// reference flies and walks that end (each replaced in the lane by the
    /// next waiting walk from `take`). The flights' torque-free constants
    /// are computed together, in lanes. The walks stay where they are in
    /// `w.lanes`; only lane numbers move.
    fn launch<T: Real, const N: usize>(
        &self,
        queue: &mut Vec<usize>,
        logs: &mut [Log],
        w: &mut Wave<T, N>,
        take: &mut impl FnMut(&mut [Log]) -> Option<Lane>,
    ) {
        let bounces = self.scene.effects().bounces as usize;
        let mut ready: Vec<usize> = Vec::with_capacity(BLOCK);
        while !queue.is_empty() {
            // Each walk on to its next flight, or ended and replaced.
            for s in queue.drain(..) {
                while let Some(l) = w.lanes[s].as_mut() {
                    match l.walk.fly(bounces) {
                        None if w.closed_form && !l.by_reference => {
                            ready.push(s);
                            break;
                        }
                        None => {
                            let log = &mut logs[l.item];
                            log.reference_flights += 1;
                            let law = self.scene.laws()[l.law];
                            if let Some(e) = self.reference_flight(law, &mut l.walk, log) {
                                l.walk.finish(e, log);
                                w.lanes[s] = take(logs);
                            }
                        }
                        Some(e) => {
                            l.walk.finish(e, &mut logs[l.item]);
                            w.lanes[s] = take(logs);
                        }
                    }
                }
                if w.lanes[s].is_none() {
                    w.times.idle(s);
                }
            }
            if ready.is_empty() {
                break;
            }
            // The flights' constants in lanes, then each flight begins (or,
            // if not closed-form, the reference flies it).
            for (j, &s) in ready.iter().enumerate() {
                let l = w.lanes[s].as_ref().expect("a ready lane has its walk");
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
            for (j, s) in ready.drain(..).enumerate() {
                let body = self.scene.body();
                let l = w.lanes[s].as_mut().expect("a ready lane has its walk");
                if w.flights.set_prepared(s, body, &l.walk.motion, &w.setup, j) {
                    w.times.begin(&w.flights, s);
                    continue;
                }
                let log = &mut logs[l.item];
                log.reference_flights += 1;
                let law = self.scene.laws()[l.law];
                if let Some(e) = self.reference_flight(law, &mut l.walk, log) {
                    l.walk.finish(e, log);
                    w.lanes[s] = take(logs);
                }
                queue.push(s);
            }
        }
    }

    /// Lane `s`'s impact: the motion at it in f64 (the centre's parabola
    /// from the flight's start, the attitude and spin from the lanes), the
    /// planes that touch and the law that solves it. With `polish` (the
    /// lanes' resolution, m), the impact is first located at contact from
    /// the lanes' state. The reference flies the flight again from its
    /// start where a second plane lies within that resolution (so that
    /// near-simultaneous impacts are its own: the error is `false`), and
    /// where the impact cannot be located (a graze, or a rocking contact
    /// within the lanes' floor, where Newton's method does not converge),
    /// and then the rest of the walk too (`true`).
    fn pending_of<T: Real>(
        &self,
        s: usize,
        lane: &Lane,
        contact_tolerance: f64,
        times: &Times<T>,
        poses: &Poses<T>,
        polish: Option<f64>,
    ) -> Result<Pending, bool> {
        let t = times.time[s].to_f64();
        let m0 = &lane.walk.motion;
        let gravity = self.flight.gravity;
        let (rotation, omega) = poses.lane(s);
        // The lanes' attitude, made orthonormal to the reference's rounding.
        let rotation = DMat3::from_quat(DQuat::from_mat3(&rotation).normalize());
        let (t, motion) = match polish {
            Some(resolution) => {
                let (f, body) = (&self.flight, self.scene.body());
                let carried = Carried::new(t, rotation, omega, TURN_STEP, MAX_TURN);
                let at = |t: f64| carried.at(body, t);
                let tol = (f.toi_tolerance, resolution);
                let Some((t, m, _)) =
                    contact_near(body, m0, &f.planes, gravity, at, t, tol, f.horizon)
                else {
                    return Err(true);
                };
                (t, m)
            }
            None => {
                let motion = Motion {
                    centre: m0.centre + m0.velocity * t + gravity * (0.5 * t * t),
                    rotation,
                    velocity: m0.velocity + gravity * t,
                    omega,
                };
                (t, motion)
            }
        };
        let body = self.scene.body();
        let (mut mask, mut near) = (0, 0);
        let mut penetrating = false;
        let semi = body.semi_axes();
        // Planes within the lanes' resolution (none without `polish`).
        let resolution = polish.unwrap_or(0.0);
        for (i, p) in self.flight.planes.iter().enumerate() {
            let u = motion.rotation.transpose() * p.normal();
            let d = p.signed_distance(motion.centre) - (semi * u).length();
            mask |= ((d.abs() <= contact_tolerance) as usize) << i;
            near += (d.abs() < resolution) as u32;
            penetrating |= d < -contact_tolerance;
        }
        if near > 1 {
            return Err(false);
        }
        let law = self.scene.laws()[lane.law];
        let several = mask.count_ones() > 1;
        let (law, coupled_fallback) = match law {
            Law::Stronge if several => (Law::Newton, true),
            law => (law, false),
        };
        Ok(Pending {
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
        })
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
            contact_tolerance,
            ..
        } = w;
        pending.sort_unstable_by_key(|p| (p.mask, law_key(p.law), p.lane));
        let mut out = Moves {
            lanes,
            logs,
            floor: self.scene.effects().energy_floor,
            tolerance: *contact_tolerance,
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
        for (s, rest) in refly.drain(..) {
            let lane = lanes[s].as_mut().expect("live lane");
            lane.by_reference |= rest;
            let log = &mut logs[lane.item];
            log.reference_flights += 1;
            let law = self.scene.laws()[lane.law];
            if let Some(e) = self.reference_flight(law, &mut lane.walk, log) {
                lane.walk.finish(e, log);
                lanes[s] = None;
            }
        }
    }
}
