//! Flights in lanes: the torque-free attitude (`pose.rs`), the constants of
//! a block of motions ([`setup`]), and the time of impact. A block of
//! flights under gravity toward N planes ([`FlightLanes`]) is searched a
//! few safe steps at a time ([`advance`]) until each lane's signed gap
//! closes or its horizon passes ([`Times`]).

// Lane code indexes SoA arrays by lane on purpose: the index form is what
// the loop vectoriser sees through.
#![allow(clippy::needless_range_loop)]

use glam::DVec3;

use crate::lanes::dispatch::{multiversioned, BLOCK};
use crate::lanes::{select, Real};
use crate::physics::TorqueFree;

mod pose;
pub mod setup;
mod special;

pub use pose::{poses, Mat3Lanes, PoseLanes, Poses};

/// A block of flights under gravity toward `N` planes, for the time of
/// impact in lanes: each lane's start (centre and velocity; its attitude
/// in [`PoseLanes`]), its spin bound and where its search starts, and what
/// every lane shares (planes, gravity, body, tolerance, horizon).
pub struct FlightLanes<T, const N: usize> {
    pub pose: Box<PoseLanes<T>>,
    /// Per plane, the centre's signed distance at the start (n·c₀ + e,
    /// from f64): distances are the start's plus the displacement's, so
    /// that their rounding is the body's and the flight's, not that of
    /// where the scene lies.
    gap0: [[T; BLOCK]; N],
    velocity: [[T; BLOCK]; 3],
    w_bound: [T; BLOCK],
    curvature: [T; BLOCK],
    start: [T; BLOCK],
    normal: [[T; 3]; N],
    gravity: [T; 3],
    /// Per plane, gravity's pull toward it: max(0, −n·g).
    gravity_toward: [T; N],
    /// The planes, gravity and tolerance in f64, for each lane's set-up.
    planes: Vec<crate::physics::Plane>,
    gravity64: DVec3,
    tolerance64: f64,
    semi: [T; 3],
    /// a − c: the support point's largest offset from the centre's normal.
    spread: T,
    tolerance: T,
    horizon: T,
}

/// Where the time-of-impact search of a block stands, per lane. A lane's
/// search is begun ([`Times::begin`]) and advanced with the block
/// ([`advance`]) until it is `done`; a wavefront begins the next flight in a
/// lane as soon as its search is done, while the other lanes go on.
pub struct Times<T> {
    /// Time from the start of the flight (s): at the impact where `hit`.
    pub time: [T; BLOCK],
    pub hit: [bool; BLOCK],
    /// The search ended: an impact, none within the horizon, or the lane's
    /// step budget spent (`stuck`: the reference then flies it).
    pub done: [bool; BLOCK],
    pub stuck: [bool; BLOCK],
    /// Steps taken by the lane's search.
    pub steps: [u32; BLOCK],
    /// Planes armed (bit i): clear of the tolerance once, so that reaching
    /// it is an impact.
    armed: [u32; BLOCK],
    /// The lane's planes have not been armed yet (a search just begun).
    fresh: [bool; BLOCK],
}

impl<T: Real> Times<T> {
    /// Every lane idle.
    pub fn new() -> Box<Self> {
        Box::new(Self {
            time: [T::ZERO; BLOCK],
            hit: [false; BLOCK],
            done: [true; BLOCK],
            stuck: [false; BLOCK],
            steps: [0; BLOCK],
            armed: [0; BLOCK],
            fresh: [false; BLOCK],
        })
    }

    /// Lane `s` begins the search of the flight set in `f` (idle if that
    /// flight is not closed-form).
    pub fn begin<const N: usize>(&mut self, f: &FlightLanes<T, N>, s: usize) {
        self.time[s] = f.start[s].min(f.horizon);
        self.hit[s] = false;
        self.done[s] = !f.pose.closed(s);
        self.stuck[s] = false;
        self.steps[s] = 0;
        self.armed[s] = 0;
        self.fresh[s] = true;
    }

    /// Lane `s` searches nothing.
    pub fn idle(&mut self, s: usize) {
        self.hit[s] = false;
        self.done[s] = true;
        self.stuck[s] = false;
    }
}

impl<T: Real, const N: usize> FlightLanes<T, N> {
    /// An empty block for `body` and `planes` (at most six). The search
    /// stops within `tolerance` of a plane, but never closer than 256 ulp
    /// of the type at the body's largest semi-axis a: distances are
    /// reckoned from the flight's start (f64) plus the displacement and
    /// less the support (at most a), so below that they cannot be resolved.
    /// In f64 the floor is some 6e-14 m per metre of a, far below the
    /// default tolerance; in f32 it is 3e-5 m per metre of a (1.5e-5 m for
    /// drop_corner's body, 9e-7 m for drop_dice's).
    pub fn new(
        body: &crate::physics::Ellipsoid,
        planes: &[crate::physics::Plane],
        gravity: DVec3,
        tolerance: f64,
        horizon: f64,
    ) -> Box<Self> {
        assert_eq!(planes.len(), N, "planes of the block");
        let t = T::from_f64;
        let semi = body.semi_axes();
        let z = [T::ZERO; BLOCK];
        Box::new(Self {
            pose: PoseLanes::new(),
            gap0: [z; N],
            velocity: [z; 3],
            w_bound: z,
            curvature: z,
            start: z,
            normal: std::array::from_fn(|i| planes[i].normal().to_array().map(t)),
            gravity: gravity.to_array().map(t),
            gravity_toward: std::array::from_fn(|i| t((-planes[i].normal().dot(gravity)).max(0.0))),
            planes: planes.to_vec(),
            gravity64: gravity,
            tolerance64: tolerance,
            semi: semi.to_array().map(t),
            spread: t(semi.max_element() - semi.min_element()),
            tolerance: t(tolerance.max(256.0 * T::EPSILON.to_f64() * semi.max_element())),
            horizon: t(horizon),
        })
    }

    /// The distance at which a search stops (m): the tolerance asked for,
    /// or the type's floor.
    pub fn tolerance(&self) -> f64 {
        self.tolerance.to_f64()
    }

    /// Lane `s` flies from `m`: its closed-form motion, spin bound and
    /// search start (the bounding sphere's clearance) as the reference sets
    /// them up. False if its rotation is not closed-form (the lane is then
    /// left to the reference).
    pub fn set(
        &mut self,
        s: usize,
        body: &crate::physics::Ellipsoid,
        m: &crate::physics::Motion,
    ) -> bool {
        let tf = TorqueFree::new(body.inertia(), m.rotation, m.omega);
        let closed = self.pose.set(s, &tf);
        self.set_flight(s, body, m);
        closed
    }

    /// [`Self::set`] with the attitude's constants from lane `j` of `c`
    /// (computed in lanes by [`setup::setup`]).
    pub fn set_prepared(
        &mut self,
        s: usize,
        body: &crate::physics::Ellipsoid,
        m: &crate::physics::Motion,
        c: &setup::Setup,
        j: usize,
    ) -> bool {
        let closed = self.pose.set_from(s, c, j);
        self.set_flight(s, body, m);
        closed
    }

    /// Lane `s`'s centre, spin bound and search start for a flight from
    /// `m`.
    fn set_flight(
        &mut self,
        s: usize,
        body: &crate::physics::Ellipsoid,
        m: &crate::physics::Motion,
    ) {
        let t = T::from_f64;
        let j = body.inertia();
        let w_bound = crate::physics::spin_bound(j, m.omega);
        let semi = body.semi_axes();
        let (a_max, a_min) = (semi.max_element(), semi.min_element());
        let j_spread = (j.max_element() - j.min_element()) / j.min_element();
        let w2 = w_bound * w_bound;
        let curvature = w2 * a_max * a_max / a_min + a_max * w2 + (a_max - a_min) * w2 * j_spread;
        for k in 0..3 {
            self.velocity[k][s] = t(m.velocity[k]);
        }
        for (i, p) in self.planes.iter().enumerate() {
            self.gap0[i][s] = t(p.signed_distance(m.centre));
        }
        self.w_bound[s] = t(w_bound);
        self.curvature[s] = t(curvature);
        self.start[s] = t(crate::physics::sphere_clearance(
            a_max,
            m,
            &self.planes,
            self.gravity64,
            self.tolerance64,
        ));
    }
}

/// Per plane, at time `t` with the lane's pose: its signed distance, the
/// normal velocity of its support point (as `ContactGeometry`) and that of
/// the centre.
#[inline(always)]
fn gap_and_rate<T: Real, const N: usize>(
    f: &FlightLanes<T, N>,
    p: &Poses<T>,
    s: usize,
    t: T,
    i: usize,
) -> (T, T, T) {
    let n = f.normal[i];
    let moved: [T; 3] =
        std::array::from_fn(|k| f.velocity[k][s] * t + T::HALF * f.gravity[k] * t * t);
    let velocity: [T; 3] = std::array::from_fn(|k| f.velocity[k][s] + f.gravity[k] * t);
    // u = Aᵀ n: column k of A dotted with n.
    let u: [T; 3] = std::array::from_fn(|k| {
        p.rotation[k][0][s] * n[0] + p.rotation[k][1][s] * n[1] + p.rotation[k][2][s] * n[2]
    });
    let (a, b, c) = (f.semi[0], f.semi[1], f.semi[2]);
    let du = [a * u[0], b * u[1], c * u[2]];
    let support = (du[0] * du[0] + du[1] * du[1] + du[2] * du[2]).sqrt();
    let distance = f.gap0[i][s] + (n[0] * moved[0] + n[1] * moved[1] + n[2] * moved[2]) - support;
    let inv = -T::ONE / support;
    let lever = [
        (b - c) * (b + c) * u[1] * u[2] * inv,
        (c - a) * (c + a) * u[2] * u[0] * inv,
        (a - b) * (a + b) * u[0] * u[1] * inv,
    ];
    let w = [p.omega[0][s], p.omega[1][s], p.omega[2][s]];
    let centre_rate = n[0] * velocity[0] + n[1] * velocity[1] + n[2] * velocity[2];
    let rate = centre_rate + lever[0] * w[0] + lever[1] * w[1] + lever[2] * w[2];
    (distance, rate, centre_rate)
}

/// The time of impact of every closed-form lane by the reference's safe
/// steps (`physics::time_of_impact`), at most `budget` steps per lane;
/// lanes still open after that are `stuck`.
pub fn times_of_impact<T: Real, const N: usize>(
    f: &FlightLanes<T, N>,
    budget: u32,
    poses_work: &mut Poses<T>,
    out: &mut Times<T>,
) {
    for s in 0..BLOCK {
        out.begin(f, s);
    }
    while advance(f, budget, budget, poses_work, out) > 0 {}
}

/// Up to `steps` steps of every open lane's search by the reference's safe
/// steps: per plane the larger of its linear and quadratic bounds, the
/// smallest over the planes, masked per lane. A lane whose search reaches
/// `budget` steps is done and `stuck`. When it returns, `poses_work` holds
/// every done lane's pose at its time (the pose of the impact, where
/// `hit`). Returns the lanes still open.
pub fn advance<T: Real, const N: usize>(
    f: &FlightLanes<T, N>,
    steps: u32,
    budget: u32,
    poses_work: &mut Poses<T>,
    out: &mut Times<T>,
) -> usize {
    let mut open = 0;
    for _ in 0..steps {
        poses(&f.pose, &out.time, poses_work);
        open = step(f, budget, poses_work, out);
        if open == 0 {
            break;
        }
    }
    open
}

multiversioned! {
    /// One step of every open lane's search at its pose in `p`, without a
    /// branch per lane: the reference's tests and bounds, selected per lane
    /// (the same arithmetic, so f64 lanes step as the reference does).
    /// Returns the lanes still open.
    fn step<T: Real, const N: usize>(
        f: &FlightLanes<T, N>,
        budget: u32,
        p: &Poses<T>,
        out: &mut Times<T>,
    ) -> usize {
        crate::lanes::dispatch::align_frame();
        let tol = f.tolerance;
        let half_tol = T::HALF * tol;
        let two = T::from_f64(2.0);
        let four = T::from_f64(4.0);
        let unbounded = f.horizon == T::INFINITY;
        // One pass per plane over the lanes, then one to move them: simple
        // loops the vectoriser takes (one loop over both did not vectorise).
        let mut armed = out.armed;
        let mut hit = [0u32; BLOCK];
        let mut dt = [T::INFINITY; BLOCK];
        for i in 0..N {
            let acc = f.gravity_toward[i];
            let pulled = acc > T::ZERO;
            for s in 0..BLOCK {
                let t = out.time[s];
                let (d, v, toward) = gap_and_rate(f, p, s, t, i);
                let fresh = out.fresh[s];
                armed[s] |= ((d > tol || (fresh && v < T::ZERO)) as u32) << i;
                let on = armed[s] >> i & 1 == 1;
                hit[s] |= (if on { d <= tol } else { v < T::ZERO }) as u32;
                let gap = select(on, d - half_tol, d + tol).max(T::ZERO);
                let speed = (-toward).max(T::ZERO) + f.w_bound[s] * f.spread;
                let root1 = (speed * speed + four * acc * gap).sqrt();
                let linear = select(
                    pulled || speed > T::ZERO,
                    select(pulled, two * gap, gap) / select(pulled, speed + root1, speed),
                    T::INFINITY,
                );
                let c = -v;
                let b = acc + f.curvature[s];
                let root = (c * c + two * b * gap).sqrt();
                let ahead = c >= T::ZERO;
                let quadratic = select(
                    ahead || b > T::ZERO,
                    select(ahead, two * gap, root - c) / select(ahead, c + root, b),
                    T::INFINITY,
                );
                dt[s] = dt[s].min(linear.max(quadratic));
            }
        }
        let mut open = 0usize;
        for s in 0..BLOCK {
            let live = !out.done[s];
            let t = out.time[s];
            let hit = hit[s] != 0;
            let ends = !hit && (t >= f.horizon || (dt[s] == T::INFINITY && unbounded));
            let moves = live && !hit && !ends;
            let steps = out.steps[s] + moves as u32;
            let stuck = moves && steps >= budget;
            let moves = moves && !stuck;
            out.hit[s] |= live && hit;
            out.stuck[s] |= stuck;
            out.done[s] = !moves;
            out.steps[s] = steps;
            out.armed[s] = if live { armed[s] } else { out.armed[s] };
            out.fresh[s] = out.fresh[s] && !live;
            out.time[s] = select(moves, t + dt[s].min(f.horizon - t).max(T::ZERO), t);
            open += moves as usize;
        }
        open
    }
}
