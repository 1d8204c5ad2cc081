//! Random inputs per sample: orientation, centre velocity (world) and angular
//! velocity (body), drawn from the scene's distributions with a counter-based
//! generator, so sample `i` is the same whatever thread, batch or lane draws
//! it.
//!
//! Draw positions per sample: 0–2 orientation, 3–8 the six velocity
//! components (Box–Muller pairs (3,4), (5,6), (7,8) give v = (z0, z1, z2) and
//! ω = (z3, z4, z5) for normal distributions; uniform distributions use 3–5
//! for v and 6–8 for ω).

// Lane code indexes SoA arrays by lane and contact on purpose: the index
// form is what the loop vectoriser sees through.
#![allow(clippy::needless_range_loop, clippy::manual_memcpy)]

use glam::{DMat3, DQuat, DVec3};

use crate::lanes::{CounterRng, Real};
use crate::scene::{OrientationDist, Scene, VectorDist};

/// Samples per SoA block: the kernel's unit of vectorised work.
pub const BLOCK: usize = 256;

/// Random words per sample.
pub const DRAWS: u32 = 9;

/// One block of drawn inputs, structure of arrays.
#[derive(Clone)]
pub struct Inputs<T> {
    /// Rotation body → world, row-major: `a[3r + c][s]` is `A_rc` of lane s.
    pub a: [[T; BLOCK]; 9],
    /// Centre velocity, world frame (m/s).
    pub v: [[T; BLOCK]; 3],
    /// Angular velocity, body frame (rad/s).
    pub w: [[T; BLOCK]; 3],
}

impl<T: Real> Inputs<T> {
    pub fn new() -> Box<Self> {
        Box::new(Self {
            a: [[T::ZERO; BLOCK]; 9],
            v: [[T::ZERO; BLOCK]; 3],
            w: [[T::ZERO; BLOCK]; 3],
        })
    }
}

#[derive(Debug, Clone, Copy)]
pub struct Sampler {
    rng: CounterRng,
    /// Draw orientations (false when nothing downstream reads them: a
    /// sphere's impact does not depend on its orientation). Skipped draws
    /// leave the identity and do not shift any other draw.
    orientation_needed: bool,
    orientation: OrientationDist,
    velocity: VectorDist,
    angular_velocity: VectorDist,
}

/// Box–Muller: two standard normals from two uniforms in (0, 1).
#[inline(always)]
fn box_muller<T: Real>(u1: T, u2: T) -> (T, T) {
    let r = (T::from_f64(-2.0) * u1.ln()).sqrt();
    let (s, c) = u2.sin_cos_2pi_unit();
    (r * c, r * s)
}

/// Shoemake's uniform unit quaternion from three uniforms (Haar on SO(3)),
/// as a rotation matrix, row-major.
#[inline(always)]
fn haar_matrix<T: Real>(u1: T, u2: T, u3: T) -> [T; 9] {
    let r1 = (T::ONE - u1).sqrt();
    let r2 = u1.sqrt();
    let (s1, c1) = u2.sin_cos_2pi_unit();
    let (s2, c2) = u3.sin_cos_2pi_unit();
    quaternion_matrix(r2 * c2, r1 * s1, r1 * c1, r2 * s2)
}

/// Rotation matrix (row-major) of the unit quaternion w + xi + yj + zk.
#[inline(always)]
fn quaternion_matrix<T: Real>(w: T, x: T, y: T, z: T) -> [T; 9] {
    let two = T::from_f64(2.0);
    let (xx, yy, zz) = (x * x, y * y, z * z);
    let (xy, xz, yz) = (x * y, x * z, y * z);
    let (wx, wy, wz) = (w * x, w * y, w * z);
    [
        T::ONE - two * (yy + zz),
        two * (xy - wz),
        two * (xz + wy),
        two * (xy + wz),
        T::ONE - two * (xx + zz),
        two * (yz - wx),
        two * (xz - wy),
        two * (yz + wx),
        T::ONE - two * (xx + yy),
    ]
}

/// `Rx(ψ)Ry(θ)Rz(φ)` row-major from angles given as turns (angle / 2π).
#[inline(always)]
fn bryan_matrix<T: Real>(psi: T, theta: T, phi: T) -> [T; 9] {
    let (sp, cp) = psi.sin_cos_2pi();
    let (st, ct) = theta.sin_cos_2pi();
    let (sf, cf) = phi.sin_cos_2pi();
    [
        ct * cf,
        -ct * sf,
        st,
        cp * sf + sp * st * cf,
        cp * cf - sp * st * sf,
        -sp * ct,
        sp * sf - cp * st * cf,
        sp * cf + cp * st * sf,
        cp * ct,
    ]
}

impl Sampler {
    pub fn new(scene: &Scene) -> Self {
        Self {
            rng: CounterRng::new(scene.seed(), DRAWS),
            orientation_needed: true,
            orientation: scene.orientation(),
            velocity: scene.velocity(),
            angular_velocity: scene.angular_velocity(),
        }
    }

    /// The same sampler, drawing orientations only if `needed`.
    pub fn with_orientation(mut self, needed: bool) -> Self {
        self.orientation_needed = needed;
        self
    }

    #[inline(always)]
    fn u<T: Real>(&self, sample: u64, j: u32) -> T {
        T::uniform(self.rng.bits(sample, j))
    }

    /// Fills a block with samples `first .. first + BLOCK`. Each distribution
    /// is matched once, outside its loop, so the loops are branch-free.
    #[inline(always)]
    pub fn fill<T: Real>(&self, first: u64, out: &mut Inputs<T>) {
        let orientation = if self.orientation_needed {
            self.orientation
        } else {
            OrientationDist::Fixed(DMat3::IDENTITY)
        };
        match orientation {
            OrientationDist::Uniform => {
                for s in 0..BLOCK {
                    let i = first + s as u64;
                    let m = haar_matrix(self.u::<T>(i, 0), self.u(i, 1), self.u(i, 2));
                    for (k, mk) in m.iter().enumerate() {
                        out.a[k][s] = *mk;
                    }
                }
            }
            OrientationDist::Fixed(a) => {
                let rows = a.transpose().to_cols_array();
                for (k, r) in rows.iter().enumerate() {
                    out.a[k] = [T::from_f64(*r); BLOCK];
                }
            }
            OrientationDist::BryanUniform { low, high } => {
                let tau = std::f64::consts::TAU;
                let lo = (low / tau).to_array().map(T::from_f64);
                let span = ((high - low) / tau).to_array().map(T::from_f64);
                for s in 0..BLOCK {
                    let i = first + s as u64;
                    let m = bryan_matrix(
                        lo[0] + span[0] * self.u(i, 0),
                        lo[1] + span[1] * self.u(i, 1),
                        lo[2] + span[2] * self.u(i, 2),
                    );
                    for (k, mk) in m.iter().enumerate() {
                        out.a[k][s] = *mk;
                    }
                }
            }
        }
        if let (VectorDist::Normal { mean: mv, sd: dv }, VectorDist::Normal { mean: mw, sd: dw }) =
            (self.velocity, self.angular_velocity)
        {
            // Both normal: the three Box–Muller pairs serve v and ω at once.
            let (mv, dv) = (
                mv.to_array().map(T::from_f64),
                dv.to_array().map(T::from_f64),
            );
            let (mw, dw) = (
                mw.to_array().map(T::from_f64),
                dw.to_array().map(T::from_f64),
            );
            for s in 0..BLOCK {
                let i = first + s as u64;
                let (z0, z1) = box_muller::<T>(self.u(i, 3), self.u(i, 4));
                let (z2, z3) = box_muller::<T>(self.u(i, 5), self.u(i, 6));
                let (z4, z5) = box_muller::<T>(self.u(i, 7), self.u(i, 8));
                let (zv, zw) = ([z0, z1, z2], [z3, z4, z5]);
                for k in 0..3 {
                    out.v[k][s] = mv[k] + dv[k] * zv[k];
                    out.w[k][s] = mw[k] + dw[k] * zw[k];
                }
            }
        } else {
            self.fill_vector(first, self.velocity, 0, &mut out.v);
            self.fill_vector(first, self.angular_velocity, 1, &mut out.w);
        }
    }

    /// `which` = 0 for v, 1 for ω.
    #[inline(always)]
    fn fill_vector<T: Real>(
        &self,
        first: u64,
        dist: VectorDist,
        which: u32,
        out: &mut [[T; BLOCK]; 3],
    ) {
        match dist {
            VectorDist::Normal { mean, sd } => {
                let m = mean.to_array().map(T::from_f64);
                let d = sd.to_array().map(T::from_f64);
                // Normals z0..z5 from pairs (3,4), (5,6), (7,8): v takes z0..z2
                // (pairs (3,4), (5,6)), ω takes z3..z5 (pairs (5,6), (7,8)).
                // Only the two pairs a vector uses are drawn.
                let base = 3 + 2 * which;
                for s in 0..BLOCK {
                    let i = first + s as u64;
                    let (a0, a1) = box_muller::<T>(self.u(i, base), self.u(i, base + 1));
                    let (b0, b1) = box_muller::<T>(self.u(i, base + 2), self.u(i, base + 3));
                    let z = if which == 0 {
                        [a0, a1, b0]
                    } else {
                        [a1, b0, b1]
                    };
                    for k in 0..3 {
                        out[k][s] = m[k] + d[k] * z[k];
                    }
                }
            }
            VectorDist::Uniform { low, high } => {
                let l = low.to_array().map(T::from_f64);
                let w = (high - low).to_array().map(T::from_f64);
                for s in 0..BLOCK {
                    let i = first + s as u64;
                    for k in 0..3 {
                        out[k][s] = l[k] + w[k] * self.u(i, 3 + 3 * which + k as u32);
                    }
                }
            }
            VectorDist::Fixed(v) => {
                for k in 0..3 {
                    out[k] = [T::from_f64(v[k]); BLOCK];
                }
            }
        }
    }

    /// The same draws for one sample in f64 with `std`'s ln, sin and cos:
    /// the reference the lane sampler is tested against.
    pub fn reference(&self, i: u64) -> (DMat3, DVec3, DVec3) {
        let u = |j: u32| -> f64 { f64::uniform(self.rng.bits(i, j)) };
        let tau = std::f64::consts::TAU;
        let a = match self.orientation {
            OrientationDist::Uniform => {
                let (r1, r2) = ((1.0 - u(0)).sqrt(), u(0).sqrt());
                let (t1, t2) = (tau * u(1), tau * u(2));
                DMat3::from_quat(DQuat::from_xyzw(
                    r1 * t1.sin(),
                    r1 * t1.cos(),
                    r2 * t2.sin(),
                    r2 * t2.cos(),
                ))
            }
            OrientationDist::Fixed(a) => a,
            OrientationDist::BryanUniform { low, high } => {
                let ang = low + (high - low) * DVec3::new(u(0), u(1), u(2));
                crate::physics::matrix_from_bryan(crate::physics::Bryan {
                    psi: ang.x,
                    theta: ang.y,
                    phi: ang.z,
                })
            }
        };
        let bm = |j: u32| {
            let r = (-2.0 * u(j).ln()).sqrt();
            let t = tau * u(j + 1);
            (r * t.cos(), r * t.sin())
        };
        let vec = |dist: VectorDist, which: u32| match dist {
            VectorDist::Normal { mean, sd } => {
                let (z0, z1) = bm(3);
                let (z2, z3) = bm(5);
                let (z4, z5) = bm(7);
                let z = if which == 0 {
                    DVec3::new(z0, z1, z2)
                } else {
                    DVec3::new(z3, z4, z5)
                };
                mean + sd * z
            }
            VectorDist::Uniform { low, high } => {
                let b = 3 + 3 * which;
                low + (high - low) * DVec3::new(u(b), u(b + 1), u(b + 2))
            }
            VectorDist::Fixed(v) => v,
        };
        (a, vec(self.velocity, 0), vec(self.angular_velocity, 1))
    }
}
