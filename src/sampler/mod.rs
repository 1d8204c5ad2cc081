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

mod orientation;
pub mod rng;
pub mod sobol;

use glam::{DMat3, DQuat, DVec3};

use crate::config::{OrientationDist, Sampling, Scene, VectorDist};
use crate::lanes::dispatch::BLOCK;
use crate::lanes::Real;
use crate::sampler::rng::CounterRng;
use crate::sampler::sobol::Sobol;
use orientation::{box_muller, bryan_matrix_at, bryan_turns, fixed_matrix, haar_matrix};

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
mod tests;
