//! The torque-free attitude in lanes: a block of flights, each with the
//! constants of its closed-form motion ([`crate::physics::TorqueFree`]),
//! evaluated at one time per lane with the reference's formulas and no
//! data-dependent loop: one `sin_cos` for the Jacobi functions and the
//! descending Landen recurrence over the block's most levels (masked per
//! lane), the theta series over its fixed twelve terms (zeros past a
//! lane's own), one `atan2`, one `sin_cos` for the precession and two 3×3
//! products. The constants are the reference's own (its set-up stays
//! scalar here); lanes whose motion is steady or near the separatrix are
//! not closed-form and are left to the reference.

// Lane code indexes SoA arrays by lane on purpose: the index form is what
// the loop vectoriser sees through.
#![allow(clippy::needless_range_loop)]

use glam::{DMat3, DVec3};

use crate::lanes::dispatch::{multiversioned, BLOCK};
use crate::lanes::{select, sin_cos, Real};
use crate::physics::{TorqueFree, THETA_TERMS};

pub mod setup;
mod special;

use setup::LEVELS;

/// A 3×3 matrix per lane, column-major: `m[col][row][lane]`.
pub type Mat3Lanes<T> = [[[T; BLOCK]; 3]; 3];

/// The constants of a block of closed-form torque-free motions, per lane.
#[repr(C, align(64))]
pub struct PoseLanes<T> {
    /// Body → relabelled body (a signed permutation), and R₀ B(l₀)ᵀ.
    perm: Mat3Lanes<T>,
    base: Mat3Lanes<T>,
    inertia: [[T; BLOCK]; 3],
    amp: [[T; BLOCK]; 3],
    sign2: [T; BLOCK],
    sign3: [T; BLOCK],
    lambda: [T; BLOCK],
    tau0: [T; BLOCK],
    two_k: [T; BLOCK],
    rate: [T; BLOCK],
    amplitude: [T; BLOCK],
    periodic0: [T; BLOCK],
    /// Jacobi: the AGM limit, the levels used (as a number), and per level
    /// the AGM's a and √(emc).
    agm: [T; BLOCK],
    levels: [T; BLOCK],
    landen_a: [[T; BLOCK]; LEVELS],
    landen_b: [[T; BLOCK]; LEVELS],
    /// The most levels of any closed-form lane of the block.
    most_levels: usize,
    /// Theta: π/(2K) and the series' coefficients (zero past a lane's
    /// terms).
    scale: [T; BLOCK],
    theta_re: [[T; BLOCK]; THETA_TERMS],
    theta_im: [[T; BLOCK]; THETA_TERMS],
    /// The lane's motion is closed-form (else the reference's).
    closed: [bool; BLOCK],
}

impl<T: Real> PoseLanes<T> {
    pub fn new() -> Box<Self> {
        let z = [T::ZERO; BLOCK];
        Box::new(Self {
            perm: [[z; 3]; 3],
            base: [[z; 3]; 3],
            inertia: [z; 3],
            amp: [z; 3],
            sign2: z,
            sign3: z,
            lambda: z,
            tau0: z,
            two_k: [T::ONE; BLOCK],
            rate: z,
            amplitude: z,
            periodic0: z,
            agm: [T::ONE; BLOCK],
            levels: z,
            landen_a: [[T::ONE; BLOCK]; LEVELS],
            landen_b: [[T::ONE; BLOCK]; LEVELS],
            most_levels: 0,
            scale: z,
            theta_re: [z; THETA_TERMS],
            theta_im: [z; THETA_TERMS],
            closed: [false; BLOCK],
        })
    }

    /// Lane `s` takes the constants of `m`. False (and the lane is not
    /// closed-form) for a steady rotation or a motion near the separatrix.
    pub fn set(&mut self, s: usize, m: &TorqueFree) -> bool {
        let closed = m.steady.is_none() && m.rk4_step.is_none();
        self.closed[s] = closed;
        if !closed {
            return false;
        }
        let t = T::from_f64;
        let (perm, base) = (m.perm.to_cols_array_2d(), m.base.to_cols_array_2d());
        for c in 0..3 {
            for r in 0..3 {
                self.perm[c][r][s] = t(perm[c][r]);
                self.base[c][r][s] = t(base[c][r]);
            }
            self.inertia[c][s] = t(m.inertia[c]);
            self.amp[c][s] = t(m.amp[c]);
        }
        self.sign2[s] = t(m.sign2);
        self.sign3[s] = t(m.sign3);
        self.lambda[s] = t(m.lambda);
        self.tau0[s] = t(m.tau0);
        self.two_k[s] = t(m.two_k);
        self.rate[s] = t(m.rate);
        self.amplitude[s] = t(m.amplitude);
        self.periodic0[s] = t(m.periodic0);
        let j = &m.jacobi;
        self.agm[s] = t(j.agm);
        self.levels[s] = t(j.levels as f64);
        for i in 0..LEVELS {
            self.landen_a[i][s] = t(j.a[i]);
            self.landen_b[i][s] = t(j.b[i]);
        }
        self.most_levels = self.most_levels.max(j.levels);
        let p = &m.phase;
        self.scale[s] = t(p.scale);
        for n in 0..THETA_TERMS {
            let on = n < p.terms;
            self.theta_re[n][s] = t(if on { p.re[n] } else { 0.0 });
            self.theta_im[n][s] = t(if on { p.im[n] } else { 0.0 });
        }
        true
    }

    /// Lane `s` takes the constants of lane `j` of `c` (computed in lanes
    /// by [`setup::setup`]). False if that motion is not closed-form.
    pub fn set_from(&mut self, s: usize, c: &setup::Setup, j: usize) -> bool {
        let closed = c.closed[j];
        self.closed[s] = closed;
        if !closed {
            return false;
        }
        let t = T::from_f64;
        for col in 0..3 {
            for row in 0..3 {
                self.perm[col][row][s] = t(c.perm[col][row][j]);
                self.base[col][row][s] = t(c.base[col][row][j]);
            }
            self.inertia[col][s] = t(c.inertia[col][j]);
            self.amp[col][s] = t(c.amp[col][j]);
        }
        self.sign2[s] = t(c.sign2[j]);
        self.sign3[s] = t(c.sign3[j]);
        self.lambda[s] = t(c.lambda[j]);
        self.tau0[s] = t(c.tau0[j]);
        self.two_k[s] = t(c.two_k[j]);
        self.rate[s] = t(c.rate[j]);
        self.amplitude[s] = t(c.amplitude[j]);
        self.periodic0[s] = t(c.periodic0[j]);
        self.agm[s] = t(c.agm[j]);
        self.levels[s] = t(c.levels[j]);
        for i in 0..LEVELS {
            self.landen_a[i][s] = t(c.landen_a[i][j]);
            self.landen_b[i][s] = t(c.landen_b[i][j]);
        }
        self.most_levels = self.most_levels.max(c.levels[j] as usize);
        self.scale[s] = t(c.scale[j]);
        for n in 0..THETA_TERMS {
            self.theta_re[n][s] = t(c.theta_re[n][j]);
            self.theta_im[n][s] = t(c.theta_im[n][j]);
        }
        true
    }

    /// Whether lane `s` is closed-form.
    pub fn closed(&self, s: usize) -> bool {
        self.closed[s]
    }
}

/// The attitudes and body angular velocities of a block.
#[repr(C, align(64))]
pub struct Poses<T> {
    pub rotation: Mat3Lanes<T>,
    pub omega: [[T; BLOCK]; 3],
}

impl<T: Real> Poses<T> {
    pub fn new() -> Box<Self> {
        Box::new(Self {
            rotation: [[[T::ZERO; BLOCK]; 3]; 3],
            omega: [[T::ZERO; BLOCK]; 3],
        })
    }

    /// Lane `s` as glam values (for comparisons with the reference).
    pub fn lane(&self, s: usize) -> (DMat3, DVec3) {
        let r = std::array::from_fn(|k| self.rotation[k / 3][k % 3][s].to_f64());
        let w = DVec3::from_array(std::array::from_fn(|k| self.omega[k][s].to_f64()));
        (DMat3::from_cols_array(&r), w)
    }
}

/// `a · b` for 3×3 matrices given by columns.
#[inline(always)]
fn mul<T: Real>(a: &[[T; 3]; 3], b: &[[T; 3]; 3]) -> [[T; 3]; 3] {
    std::array::from_fn(|c| {
        std::array::from_fn(|r| a[0][r] * b[c][0] + a[1][r] * b[c][1] + a[2][r] * b[c][2])
    })
}

multiversioned! {
    /// Every closed-form lane's attitude and body angular velocity at its
    /// time `t[s]` (seconds from the start of its motion). Other lanes'
    /// outputs are unspecified. Three passes over the lanes, each an inner
    /// loop the vectoriser takes: the Jacobi functions' start, the Landen
    /// levels (one pass per level, masked), the rest.
    pub fn poses<T: Real>(c: &PoseLanes<T>, t: &[T; BLOCK], out: &mut Poses<T>) {
        crate::lanes::dispatch::align_frame();
        let two = T::from_f64(2.0);
        let mut tau_r = [T::ZERO; BLOCK];
        let mut turns = [T::ZERO; BLOCK];
        let (mut sn0, mut cn0) = ([T::ZERO; BLOCK], [T::ZERO; BLOCK]);
        let (mut a, mut cc, mut dn) = ([T::ZERO; BLOCK], [T::ZERO; BLOCK], [T::ONE; BLOCK]);
        for s in 0..BLOCK {
            let tau = c.tau0[s] + c.lambda[s] * t[s];
            let k = (tau / c.two_k[s]).round();
            turns[s] = k;
            tau_r[s] = tau - k * c.two_k[s];
            let (sv, cv) = sin_cos(tau_r[s] * c.agm[s]);
            (sn0[s], cn0[s]) = (sv, cv);
            a[s] = cv / select(sv != T::ZERO, sv, T::ONE);
            cc[s] = c.agm[s] * a[s];
        }
        // Jacobi's sn, cn, dn by the descending Landen recurrence.
        for i in (0..c.most_levels).rev() {
            let level = T::from_f64(i as f64);
            for s in 0..BLOCK {
                let on = level < c.levels[s];
                let b = c.landen_a[i][s];
                let a1 = a[s] * cc[s];
                let c1 = cc[s] * dn[s];
                let d1 = (c.landen_b[i][s] + a1) / (b + a1);
                a[s] = select(on, c1 / b, a[s]);
                cc[s] = select(on, c1, cc[s]);
                dn[s] = select(on, d1, dn[s]);
            }
        }
        for s in 0..BLOCK {
            let nonzero = sn0[s] != T::ZERO;
            let r = T::ONE / (cc[s] * cc[s] + T::ONE).sqrt();
            let sn1 = select(sn0[s] >= T::ZERO, r, -r);
            let sn = select(nonzero, sn1, sn0[s]);
            let cn = select(nonzero, cc[s] * sn1, cn0[s]);
            let dn = select(nonzero, dn[s], T::ONE);
            // An odd number of half periods flips sn and cn.
            let half = turns[s] * T::HALF;
            let flip = select(half.round() == half, T::ONE, -T::ONE);
            let wp = [
                c.amp[0][s] * (flip * cn),
                c.sign2[s] * c.amp[1][s] * (flip * sn),
                c.sign3[s] * c.amp[2][s] * dn,
            ];
            // The theta series' argument, arg Θ(u + iβ).
            let (s1, c1) = sin_cos(two * c.scale[s] * tau_r[s]);
            let (mut re, mut im) = (T::ONE, T::ZERO);
            let (mut cp, mut sp) = (T::ONE, T::ZERO);
            let (mut cn_, mut sn_) = (c1, s1);
            for n in 0..THETA_TERMS {
                re += c.theta_re[n][s] * cn_;
                im = im - c.theta_im[n][s] * sn_;
                let (c2, s2) = (two * c1 * cn_ - cp, two * c1 * sn_ - sp);
                (cp, sp, cn_, sn_) = (cn_, sn_, c2, s2);
            }
            let periodic = im.atan2(re);
            let phi = c.rate[s] * t[s] + c.amplitude[s] * (periodic - c.periodic0[s]);
            // R = base · Rz(φ) · B(l), l = J ω / |J ω| in relabelled axes.
            let lp = [c.inertia[0][s] * wp[0], c.inertia[1][s] * wp[1], c.inertia[2][s] * wp[2]];
            let ln = (lp[0] * lp[0] + lp[1] * lp[1] + lp[2] * lp[2]).sqrt();
            let l = [lp[0] / ln, lp[1] / ln, lp[2] / ln];
            let st = (l[0] * l[0] + l[1] * l[1]).sqrt();
            let tilted = st > T::ZERO;
            let safe = select(tilted, st, T::ONE);
            let spsi = select(tilted, l[0] / safe, T::ZERO);
            let cpsi = select(tilted, l[1] / safe, T::ONE);
            let ct = l[2];
            let z = T::ZERO;
            let rz = [[cpsi, spsi, z], [-spsi, cpsi, z], [z, z, T::ONE]];
            let rx = [[T::ONE, z, z], [z, ct, st], [z, -st, ct]];
            let (sphi, cphi) = sin_cos(phi);
            let rphi = [[cphi, sphi, z], [-sphi, cphi, z], [z, z, T::ONE]];
            let base = std::array::from_fn(|col| std::array::from_fn(|row| c.base[col][row][s]));
            let perm: [[T; 3]; 3] =
                std::array::from_fn(|col| std::array::from_fn(|row| c.perm[col][row][s]));
            let rot = mul(&mul(&mul(&base, &rphi), &mul(&rx, &rz)), &perm);
            for col in 0..3 {
                for row in 0..3 {
                    out.rotation[col][row][s] = rot[col][row];
                }
                // ω = permᵀ ω': column `col` of perm dotted with ω'.
                out.omega[col][s] =
                    perm[col][0] * wp[0] + perm[col][1] * wp[1] + perm[col][2] * wp[2];
            }
        }
    }
}

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
