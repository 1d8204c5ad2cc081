//! Random inputs per sample: orientation, centre velocity (world) and angular
//! velocity (body), drawn from the scene's distributions with a counter-based
//! generator, so sample `i` is the same whatever thread, batch or lane draws
//! it.
//!
//! Draw positions per sample: 0–2 orientation, 3–8 the six velocity
//! components (Box–Muller pairs (3,4), (5,6), (7,8) give v = (z0, z1, z2) and
//! ω = (z3, z4, z5) for normal distributions; uniform distributions use 3–5
//! for v and 6–8 for ω).
//!
//! Bits per draw: a sample has [`WORDS`] 64-bit words of the counter-based
//! generator. Draw j's top 32 bits are half j mod 2 (high half first) of
//! word ⌊j/2⌋, words 0–4; f32 draws use nothing else (the top 23 of those
//! bits), so an f32 sample hashes 5 words, not 9. f64 draws add 20 low
//! bits: bits 20·(j mod 3) … of word 5 + ⌊j/3⌋, so an f64 sample hashes 8.
//! The f32 draw is the f64 draw's top bits, so the two precisions draw the
//! same samples (the accuracy ladder's f32-against-f64 rung relies on it).

// Lane code indexes SoA arrays by lane and contact on purpose: the index
// form is what the loop vectoriser sees through.
#![allow(clippy::needless_range_loop, clippy::manual_memcpy)]

use glam::{DMat3, DQuat, DVec3};

use crate::lanes::{CounterRng, Real};
use crate::scene::{OrientationDist, Scene, VectorDist};

/// Samples per SoA block: the kernel's unit of vectorised work (a multiple
/// of 16). Chosen by measurement, end to end on Zen 4 (2026-11-24): 256
/// made S3 f64 14 % slower (its blocks hold about 640 bytes per lane) and
/// 128 made f32 about 3 % slower; 192 is within noise of the best for S1
/// and S3 in both precisions.
pub const BLOCK: usize = 192;

/// Random 64-bit words per sample (see the module notes).
pub const WORDS: u32 = 8;

/// The first of the words that hold the f64 draws' 20 low bits (draw j's
/// are bits 20·(j mod 3) … of word `LOW_WORD + ⌊j/3⌋`).
const LOW_WORD: u32 = 5;

/// One block of drawn inputs, structure of arrays, cache-line aligned.
#[derive(Clone)]
#[repr(C, align(64))]
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
            rng: CounterRng::new(scene.seed(), WORDS),
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

    /// Uniform draw `j` of sample `sample` (j is a constant in every
    /// caller, so the half and word choices fold away, and the words shared
    /// by two draws are hashed once).
    #[inline(always)]
    fn u<T: Real>(&self, sample: u64, j: u32) -> T {
        let w = self.rng.bits(sample, j / 2);
        let hi = if j % 2 == 0 {
            (w >> 32) as u32
        } else {
            w as u32
        };
        let lo = self.rng.bits(sample, LOW_WORD + j / 3) >> (20 * (j % 3));
        T::uniform_split(hi, lo)
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
                    out.v[k][s] = dv[k].mul_add(zv[k], mv[k]);
                    out.w[k][s] = dw[k].mul_add(zw[k], mw[k]);
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
                        out[k][s] = d[k].mul_add(z[k], m[k]);
                    }
                }
            }
            VectorDist::Uniform { low, high } => {
                let l = low.to_array().map(T::from_f64);
                let w = (high - low).to_array().map(T::from_f64);
                for s in 0..BLOCK {
                    let i = first + s as u64;
                    for k in 0..3 {
                        out[k][s] = w[k].mul_add(self.u(i, 3 + 3 * which + k as u32), l[k]);
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
        // Bits as the module notes say, written out independently of `u`.
        let u = |j: u32| -> f64 {
            let word = self.rng.bits(i, j / 2);
            let top32 = if j % 2 == 0 {
                word >> 32
            } else {
                word & 0xffff_ffff
            };
            let low20 = (self.rng.bits(i, 5 + j / 3) >> (20 * (j % 3))) & 0xf_ffff;
            ((top32 << 20 | low20) as f64 + 0.5) / 4_503_599_627_370_496.0
        };
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

#[cfg(test)]
mod tests {
    use super::*;

    fn sampler(seed: u64) -> Sampler {
        Sampler {
            rng: CounterRng::new(seed, WORDS),
            orientation_needed: true,
            orientation: OrientationDist::Uniform,
            velocity: VectorDist::Fixed(DVec3::ZERO),
            angular_velocity: VectorDist::Fixed(DVec3::ZERO),
        }
    }

    /// Value stability of the draws: the 52-bit integers k of the f64
    /// uniforms (k + ½)·2⁻⁵², computed once from the module notes' word
    /// layout by an independent Python implementation of SplitMix64.
    /// Changing them changes every seeded result: a deliberate decision and
    /// a version bump.
    #[test]
    fn draws_are_frozen() {
        let s = sampler(42);
        let want: [(u64, [u64; 9]); 2] = [
            (
                0,
                [
                    2029098098584163,
                    1201813910028967,
                    2473972865410187,
                    3352543597182741,
                    4066727417352526,
                    583196261555283,
                    4140893753844133,
                    56444775705590,
                    4415853579443453,
                ],
            ),
            (
                1_000_000_007,
                [
                    146971034081284,
                    261147499335548,
                    3839864956428190,
                    1801187253391987,
                    834816944512625,
                    1545269381926959,
                    4503127835676428,
                    4095400509254592,
                    572114929692372,
                ],
            ),
        ];
        for (i, ks) in want {
            for (j, k) in ks.into_iter().enumerate() {
                let u = (k as f64 + 0.5) / 4_503_599_627_370_496.0;
                assert_eq!(s.u::<f64>(i, j as u32), u, "sample {i} draw {j}");
                // The f32 draw is the f64 draw's top 23 bits.
                let u32_ = ((k >> 29) as f64 + 0.5) / 8_388_608.0;
                assert_eq!(s.u::<f32>(i, j as u32) as f64, u32_, "sample {i} draw {j}");
            }
        }
    }

    /// Every draw of a sample uses bits no other draw of it uses.
    #[test]
    fn draws_of_a_sample_are_distinct() {
        let s = sampler(7);
        for i in 0..1000u64 {
            let mut us: Vec<f64> = (0..DRAWS_PER_SAMPLE).map(|j| s.u::<f64>(i, j)).collect();
            us.sort_by(f64::total_cmp);
            us.dedup();
            assert_eq!(us.len(), DRAWS_PER_SAMPLE as usize);
        }
    }

    const DRAWS_PER_SAMPLE: u32 = 9;
}
