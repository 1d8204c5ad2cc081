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
//!
//! A drop's start position in its release box takes three more draws,
//! positions 9–11, from a stream of its own ([`rng::DROP_START_STREAM`]).
//!
//! With RQMC (`sampling = "rqmc"`) draw j's top 32 bits are coordinate j
//! of an Owen-scrambled Sobol point ([`sobol`]); the f64 draws' 20 low bits
//! come from the same words as with MC. Nothing else changes: each draw
//! position is one dimension of the point, skipped draws shift no other,
//! and the transforms (Shoemake, Box–Muller, affine, Bryan) are the same.

// Lane code indexes SoA arrays by lane and contact on purpose: the index
// form is what the loop vectoriser sees through.
#![allow(clippy::needless_range_loop, clippy::manual_memcpy)]

pub mod rng;
pub mod sobol;

use glam::{DMat3, DQuat, DVec3};

use crate::config::{OrientationDist, Sampling, Scene, VectorDist};
use crate::lanes::dispatch::BLOCK;
use crate::lanes::Real;
use crate::sampler::rng::CounterRng;
use crate::sampler::sobol::Sobol;

/// Every row of the orientation matrix (see [`Sampler::with_matrix_rows`]).
pub const ALL_ROWS: u8 = 0b111;

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

/// Where the top 32 bits of a draw come from.
#[derive(Debug, Clone, Copy)]
enum Points {
    /// The counter-based generator's words (module notes).
    Mc,
    /// Scrambled Sobol points: draw j is dimension j.
    Rqmc(Sobol),
}

/// The stream key of the RQMC scrambles (mixed with the seed).
const SOBOL_STREAM: u64 = 0x50b0_1000_5c4a_3b1e;

/// Draw positions of a drop's start position (module notes).
const START_DRAW: u32 = 9;

#[derive(Debug, Clone, Copy)]
pub struct Sampler {
    rng: CounterRng,
    /// A drop's start positions' words.
    boxes: CounterRng,
    points: Points,
    /// Draw orientations (false when nothing downstream reads them: a
    /// sphere's impact does not depend on its orientation). Skipped draws
    /// leave the identity and do not shift any other draw.
    orientation_needed: bool,
    /// Rows of the orientation matrix a caller reads (bit r: row r): a
    /// Haar orientation writes only these (the others keep scratch), and
    /// [`Self::orientation_of`] gives a lane's whole matrix when needed.
    matrix_rows: u8,
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

/// A fixed orientation's matrix, row-major, in the lane type.
fn fixed_matrix<T: Real>(a: DMat3) -> [T; 9] {
    a.transpose().to_cols_array().map(T::from_f64)
}

/// The Bryan angle ranges `[low, high]` (radians) as turns: `(low, span)`.
fn bryan_turns<T: Real>(low: DVec3, high: DVec3) -> ([T; 3], [T; 3]) {
    let tau = std::f64::consts::TAU;
    (
        (low / tau).to_array().map(T::from_f64),
        ((high - low) / tau).to_array().map(T::from_f64),
    )
}

/// [`bryan_matrix`] at the angles `low + span·u` (turns) for uniforms `u`.
#[inline(always)]
fn bryan_matrix_at<T: Real>(lo: [T; 3], span: [T; 3], u: [T; 3]) -> [T; 9] {
    bryan_matrix(
        lo[0] + span[0] * u[0],
        lo[1] + span[1] * u[1],
        lo[2] + span[2] * u[2],
    )
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
        let points = match scene.sampling() {
            Sampling::Mc => Points::Mc,
            Sampling::Rqmc { log2_points, .. } => {
                Points::Rqmc(Sobol::new(scene.seed() ^ SOBOL_STREAM, log2_points))
            }
        };
        Self {
            rng: CounterRng::new(scene.seed() ^ rng::SAMPLE_STREAM, WORDS),
            boxes: rng::drop_start_rng(scene.seed()),
            points,
            orientation_needed: true,
            matrix_rows: ALL_ROWS,
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

    /// The same sampler, writing only rows `rows` (bit r: row r) of a
    /// uniform orientation's matrix: a one-plane scene along an axis reads
    /// one row. Fixed and Bryan orientations still write every row.
    pub fn with_matrix_rows(mut self, rows: u8) -> Self {
        assert!(rows != 0 && rows <= ALL_ROWS, "matrix rows {rows:#b}");
        self.matrix_rows = rows;
        self
    }

    /// The orientation distribution drawn from: the identity when
    /// orientations are not needed.
    fn drawn_orientation(&self) -> OrientationDist {
        if self.orientation_needed {
            self.orientation
        } else {
            OrientationDist::Fixed(DMat3::IDENTITY)
        }
    }

    /// Whether [`Self::fill`] leaves rows of a drawn orientation unwritten.
    pub fn partial_rows(&self) -> bool {
        self.matrix_rows != ALL_ROWS && matches!(self.drawn_orientation(), OrientationDist::Uniform)
    }

    /// Sample `i`'s whole orientation matrix (row-major), in `T` as
    /// [`Self::fill`] computes it, bit for bit (the same operations, one
    /// lane). For lanes a partial fill must complete.
    pub fn orientation_of<T: Real>(&self, i: u64) -> [T; 9] {
        let u = [0, 1, 2].map(|j| self.u::<T>(i, j));
        match self.drawn_orientation() {
            OrientationDist::Uniform => haar_matrix(u[0], u[1], u[2]),
            OrientationDist::Fixed(a) => fixed_matrix(a),
            OrientationDist::BryanUniform { low, high } => {
                let (lo, span) = bryan_turns(low, high);
                bryan_matrix_at(lo, span, u)
            }
        }
    }

    /// A Haar orientation's rows `ROWS` (bit r: row r) into `out.a`, from
    /// the draws in rows 0–2. Entries not stored are not computed (about
    /// 1.5 % of two-thread S1's time for the two rows it does not read).
    #[inline(always)]
    fn haar_rows<T: Real, const ROWS: u8>(out: &mut Inputs<T>) {
        for s in 0..BLOCK {
            let m = haar_matrix(out.a[0][s], out.a[1][s], out.a[2][s]);
            for (k, mk) in m.iter().enumerate() {
                if ROWS & (1 << (k / 3)) != 0 {
                    out.a[k][s] = *mk;
                }
            }
        }
    }

    /// Uniform draw `j` of sample `sample` (j is a constant in every
    /// caller, so the half and word choices fold away, and the words shared
    /// by two draws are hashed once).
    #[inline(always)]
    fn u<T: Real>(&self, sample: u64, j: u32) -> T {
        T::uniform_split(self.top32(sample, j), self.low20(sample, j))
    }

    /// Draw j's top 32 bits (module notes).
    #[inline(always)]
    fn top32(&self, sample: u64, j: u32) -> u32 {
        match self.points {
            Points::Mc => {
                let w = self.rng.bits(sample, j / 2);
                if j % 2 == 0 {
                    (w >> 32) as u32
                } else {
                    w as u32
                }
            }
            Points::Rqmc(sobol) => sobol.point(sample, j as usize),
        }
    }

    /// Draw j's low bits in f64 (the low 20 bits of the result count).
    #[inline(always)]
    fn low20(&self, sample: u64, j: u32) -> u64 {
        self.rng.bits(sample, LOW_WORD + j / 3) >> (20 * (j % 3))
    }

    /// The three uniforms of sample `i`'s start position in a drop's
    /// release box, in f64: draws 9–11 (module notes).
    pub fn start_uniforms(&self, i: u64) -> [f64; 3] {
        std::array::from_fn(|k| {
            let bits = self.boxes.bits(i, k as u32);
            match self.points {
                Points::Mc => f64::uniform(bits),
                Points::Rqmc(sobol) => {
                    f64::uniform_split(sobol.point(i, (START_DRAW + k as u32) as usize), bits)
                }
            }
        })
    }

    /// The RQMC replicate of sample `i` (none with MC).
    pub fn replicate(&self, i: u64) -> Option<u64> {
        match self.points {
            Points::Mc => None,
            Points::Rqmc(sobol) => Some(sobol.replicate(i)),
        }
    }

    /// The uniform draws `LO .. HI` of samples `first .. first + BLOCK`
    /// into `rows[j]`, in one loop, so every word is hashed once even when
    /// it holds draws of several distributions.
    #[inline(always)]
    fn uniforms<T: Real, const LO: usize, const HI: usize>(
        &self,
        first: u64,
        rows: &mut [[T; BLOCK]; 9],
    ) {
        match self.points {
            Points::Mc => {
                for s in 0..BLOCK {
                    let i = first + s as u64;
                    for j in LO..HI {
                        rows[j][s] = self.u(i, j as u32);
                    }
                }
            }
            // A dimension at a time (a block lies in one replicate:
            // batches are whole replicates or parts of one; lanes past a
            // batch's end draw valid, unused values). An f32 draw is its
            // top bits alone.
            Points::Rqmc(sobol) if size_of::<T>() == 4 => {
                for j in LO..HI {
                    sobol.points_map(first, j, &mut rows[j], |hi| T::uniform_split(hi, 0));
                }
            }
            Points::Rqmc(sobol) => {
                // The top bits first, then the f64 low bits per sample as
                // above (each word hashed once).
                let mut top = [[0u32; BLOCK]; 9];
                for j in LO..HI {
                    sobol.points(first, j, &mut top[j]);
                }
                for s in 0..BLOCK {
                    let i = first + s as u64;
                    for j in LO..HI {
                        rows[j][s] = T::uniform_split(top[j][s], self.low20(i, j as u32));
                    }
                }
            }
        }
    }

    /// Fills a block with samples `first .. first + BLOCK`. Each distribution
    /// is matched once, outside its loop, so the loops are branch-free.
    ///
    /// The uniforms go first, in a pass of their own, into `out.a`'s nine
    /// rows (row j holds draw j); the velocities and then the orientations
    /// are made from them in place. Hashing and transforming in one loop
    /// left a long chain of dependent operations per sample in a large loop
    /// body, which the CPU could not overlap across iterations: the separate
    /// pass made the draws about 10 % faster (Zen 4, 2026-11-24), although
    /// it stores and reloads every uniform. The draws are the same bit for bit.
    #[inline(always)]
    pub fn fill<T: Real>(&self, first: u64, out: &mut Inputs<T>) {
        let orientation = self.drawn_orientation();
        let random_orientation = !matches!(orientation, OrientationDist::Fixed(_));
        let normals = match (self.velocity, self.angular_velocity) {
            (VectorDist::Normal { mean: mv, sd: dv }, VectorDist::Normal { mean: mw, sd: dw }) => {
                Some((mv, dv, mw, dw))
            }
            _ => None,
        };
        // Draws 0–2 are the orientation's, 3–8 the velocities' (module notes).
        match (random_orientation, normals.is_some()) {
            (true, true) => self.uniforms::<T, 0, 9>(first, &mut out.a),
            (true, false) => self.uniforms::<T, 0, 3>(first, &mut out.a),
            (false, true) => self.uniforms::<T, 3, 9>(first, &mut out.a),
            (false, false) => {}
        }
        // Velocities first: they read rows 3–8, which the orientation
        // overwrites.
        if let Some((mv, dv, mw, dw)) = normals {
            // Both normal: the three Box–Muller pairs serve v and ω at once.
            let (mv, dv) = (
                mv.to_array().map(T::from_f64),
                dv.to_array().map(T::from_f64),
            );
            let (mw, dw) = (
                mw.to_array().map(T::from_f64),
                dw.to_array().map(T::from_f64),
            );
            let u = &out.a;
            for s in 0..BLOCK {
                let (z0, z1) = box_muller::<T>(u[3][s], u[4][s]);
                let (z2, z3) = box_muller::<T>(u[5][s], u[6][s]);
                let (z4, z5) = box_muller::<T>(u[7][s], u[8][s]);
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
        match orientation {
            OrientationDist::Uniform => match self.matrix_rows {
                1 => Self::haar_rows::<T, 1>(out),
                2 => Self::haar_rows::<T, 2>(out),
                3 => Self::haar_rows::<T, 3>(out),
                4 => Self::haar_rows::<T, 4>(out),
                5 => Self::haar_rows::<T, 5>(out),
                6 => Self::haar_rows::<T, 6>(out),
                _ => Self::haar_rows::<T, ALL_ROWS>(out),
            },
            OrientationDist::Fixed(a) => {
                for (k, r) in fixed_matrix::<T>(a).into_iter().enumerate() {
                    out.a[k] = [r; BLOCK];
                }
            }
            OrientationDist::BryanUniform { low, high } => {
                let (lo, span) = bryan_turns(low, high);
                for s in 0..BLOCK {
                    let u = [out.a[0][s], out.a[1][s], out.a[2][s]];
                    let m = bryan_matrix_at(lo, span, u);
                    for (k, mk) in m.iter().enumerate() {
                        out.a[k][s] = *mk;
                    }
                }
            }
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
            let top32 = match self.points {
                Points::Mc if j % 2 == 0 => word >> 32,
                Points::Mc => word & 0xffff_ffff,
                Points::Rqmc(sobol) => sobol.point(i, j as usize) as u64,
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
            boxes: rng::drop_start_rng(seed),
            points: Points::Mc,
            orientation_needed: true,
            matrix_rows: ALL_ROWS,
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

    /// A fill of some rows of a Haar orientation writes exactly what the
    /// whole fill writes in those rows, and `orientation_of` gives the
    /// whole fill's matrix bit for bit, in both lane types (a lane the
    /// reference recomputes is completed with it).
    fn partial_rows_are_the_whole_fill<T: Real>() {
        for points in [Points::Mc, Points::Rqmc(Sobol::new(5, 11))] {
            partial_rows_are_the_whole_fill_with::<T>(points);
        }
    }

    fn partial_rows_are_the_whole_fill_with<T: Real>(points: Points) {
        let mut s = sampler(5);
        s.points = points;
        s.velocity = VectorDist::Normal {
            mean: DVec3::new(0.0, 0.0, -1.0),
            sd: DVec3::splat(0.5),
        };
        s.angular_velocity = s.velocity;
        // RQMC: across the lookup table's runs, in one replicate.
        let first = 5 * BLOCK as u64;
        let mut whole = Inputs::<T>::new();
        // `orientation_of` is every distribution's fill, lane by lane (the
        // Haar one last: `whole` keeps it for the partial fills below).
        for orientation in [
            OrientationDist::Fixed(DMat3::from_rotation_y(0.7)),
            OrientationDist::BryanUniform {
                low: DVec3::new(-0.5, 0.1, -3.0),
                high: DVec3::new(0.5, 1.2, 3.0),
            },
            s.orientation,
        ] {
            let other = Sampler { orientation, ..s };
            other.fill(first, &mut whole);
            for l in 0..BLOCK {
                let a = other.orientation_of::<T>(first + l as u64);
                for k in 0..9 {
                    assert_eq!(
                        a[k].to_f64().to_bits(),
                        whole.a[k][l].to_f64().to_bits(),
                        "{orientation:?} lane {l} entry {k}"
                    );
                }
            }
        }
        assert!(matches!(s.orientation, OrientationDist::Uniform));
        for rows in 1..ALL_ROWS {
            let part = s.with_matrix_rows(rows);
            assert!(part.partial_rows());
            let mut x = Inputs::<T>::new();
            part.fill(first, &mut x);
            for k in 0..9 {
                if rows & (1 << (k / 3)) != 0 {
                    assert!(x.a[k] == whole.a[k], "rows {rows:#b}: entry {k}");
                }
            }
            assert!(
                x.v == whole.v && x.w == whole.w,
                "rows {rows:#b}: velocities"
            );
        }
        assert!(!s.partial_rows());
    }

    #[test]
    fn partial_rows_are_the_whole_fill_f32() {
        partial_rows_are_the_whole_fill::<f32>();
    }

    #[test]
    fn partial_rows_are_the_whole_fill_f64() {
        partial_rows_are_the_whole_fill::<f64>();
    }

    /// Every combination of the distributions and both sampling methods
    /// (each pass of `fill` reads
    /// its draws from the rows the uniform pass wrote, before the
    /// orientation overwrites them): the lanes give the reference sampler's
    /// inputs, in f64 to rounding, with orientations skipped or not.
    #[test]
    fn every_combination_of_distributions_matches_the_reference() {
        let orientations = [
            OrientationDist::Uniform,
            OrientationDist::Fixed(DMat3::from_rotation_x(0.3) * DMat3::from_rotation_z(1.1)),
            OrientationDist::BryanUniform {
                low: DVec3::new(-0.5, 0.1, -3.0),
                high: DVec3::new(0.5, 1.2, 3.0),
            },
        ];
        let vectors = [
            VectorDist::Normal {
                mean: DVec3::new(-1.0, 0.5, -2.0),
                sd: DVec3::new(0.5, 1.5, 0.25),
            },
            VectorDist::Uniform {
                low: DVec3::new(-1.0, 0.0, -4.0),
                high: DVec3::new(1.0, 0.5, -2.0),
            },
            VectorDist::Fixed(DVec3::new(0.25, -0.5, 2.0)),
        ];
        // RQMC: samples 960..1152 of replicate 0 of 2^11, across the
        // lookup table's runs.
        let first = 5 * BLOCK as u64;
        let mut x = Inputs::<f64>::new();
        for orientation in orientations {
            for velocity in vectors {
                for angular_velocity in vectors {
                    for (orientation_needed, points) in [
                        (true, Points::Mc),
                        (false, Points::Mc),
                        (true, Points::Rqmc(Sobol::new(3, 11))),
                        (false, Points::Rqmc(Sobol::new(3, 11))),
                    ] {
                        let s = Sampler {
                            rng: CounterRng::new(11, WORDS),
                            boxes: rng::drop_start_rng(11),
                            points,
                            orientation_needed,
                            matrix_rows: ALL_ROWS,
                            orientation,
                            velocity,
                            angular_velocity,
                        };
                        s.fill(first, &mut x);
                        let case = format!("{orientation:?} {velocity:?} {angular_velocity:?} {orientation_needed} {points:?}");
                        for l in 0..BLOCK {
                            let (a, v, w) = s.reference(first + l as u64);
                            let a = if orientation_needed {
                                a
                            } else {
                                DMat3::IDENTITY
                            };
                            let got_a = DMat3::from_cols_array(&std::array::from_fn(|k| x.a[k][l]))
                                .transpose();
                            let err = (got_a - a)
                                .to_cols_array()
                                .iter()
                                .chain(
                                    (DVec3::from_array(std::array::from_fn(|k| x.v[k][l])) - v)
                                        .as_ref(),
                                )
                                .chain(
                                    (DVec3::from_array(std::array::from_fn(|k| x.w[k][l])) - w)
                                        .as_ref(),
                                )
                                .fold(0f64, |m, e| m.max(e.abs()));
                            assert!(err < 1e-13, "{case}, lane {l}: {err:e}");
                        }
                    }
                }
            }
        }
    }
}
