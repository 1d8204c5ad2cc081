//! The friction kernel's state on a block, apart from the passes that use
//! it: the scene's friction constants, the contact frames, one law's
//! Gauss–Seidel sweep with its single-contact solve, and the queue of the
//! lanes still sweeping. The files beside this one hold the passes.

use crate::config::Scene;
use crate::lanes::dispatch::BLOCK;
use crate::lanes::Real;
use crate::physics::friction::JUMP_TOL;

/// Intervals of the slide angle's grid over [0, 2π).
pub(super) const GRID: usize = 32;

/// Contact i's last visit took the stick case (bit `STICK_SHIFT + i` of
/// the sweep bits).
pub(super) const STICK_SHIFT: u32 = 0;
/// Some visit of the lane could not be certified.
pub(super) const UNSURE: u32 = 1 << 8;

/// `flag` when `c` holds, else 0, without a branch (for the sweep's own
/// bits, which are not a [`crate::kernel::Status`]).
#[inline(always)]
pub(super) fn bit(c: bool, flag: u32) -> u32 {
    (c as u32) * flag
}
/// Contact i's velocity changed after its last visit (bit
/// `MOVED_SHIFT + i`): another contact's impulse moved since.
pub(super) const MOVED_SHIFT: u32 = 12;

/// The friction constants of a scene for the lane kernel.
#[derive(Debug, Clone)]
pub struct FrictionConsts<T, const N: usize> {
    pub(super) mu: [T; N],
    /// t₁, t₂ of each touching plane (world): the tangent basis the
    /// reference uses, though no result depends on it.
    pub(super) tangent: [[[T; 3]; 2]; N],
    /// cos θ_j, sin θ_j, cos 2θ_j, sin 2θ_j at θ_j = 2πj/GRID, j ≤ GRID.
    pub(super) grid: [[T; 4]; GRID + 1],
    /// The grid step 2π/GRID and half of it.
    pub(super) h: T,
    pub(super) half_h: T,
    /// Decisions closer than these to their boundary are not taken here:
    /// `take_off_band`, |a| against 0 and a contact's final sliding speed
    /// against friction.md's stick threshold, relative to the velocity
    /// scale; `stick_band`, |f| against μλ in the stick test, relative;
    /// `slide_hi` and `slide_lo`, a slide root's speed above and below the
    /// threshold, relative to the velocity scale; `round`, the
    /// certificate's values, relative to their terms' magnitude.
    pub(super) take_off_band: T,
    pub(super) stick_band: T,
    pub(super) slide_hi: T,
    pub(super) slide_lo: T,
    pub(super) round: T,
    /// The refined angle's last Newton step must be below this (rad).
    pub(super) angle_tol: T,
    /// Gauss–Seidel's stopping rule: no impulse moved by more than this
    /// times `m (|v| + L|ω|)` in a sweep (friction.md: 1e-13 in f64).
    pub(super) gs_tol: T,
    /// Sweeps after which a block's unconverged lanes go to the reference.
    pub(super) gs_max: u32,
    /// B3's bound, 2 less a margin for the lane type's rounding.
    pub(super) b3_bound: T,
    /// Newton steps from the certified start direction.
    pub(super) certified_steps: u32,
    /// friction.md's acceleration of `newton`'s Gauss–Seidel: several
    /// contacts, every μ < 0.5.
    pub(super) accelerate: bool,
    /// Sweeps between its checks.
    pub(super) accelerate_period: u32,
    /// Its Newton point's stop, relative to the impulse scale: the
    /// reference's in f64 lanes; in f32 lanes, where the point is rounded
    /// to f32, a hundredth of f32's rounding.
    pub(super) jump_tol: f64,
}

impl<T: Real, const N: usize> FrictionConsts<T, N> {
    pub fn new(scene: &Scene) -> Self {
        let f32_lanes = T::EPSILON.to_f64() > 1e-10;
        let planes = scene.touching_planes();
        let tau = std::f64::consts::TAU;
        let h = tau / GRID as f64;
        // friction.md's stick threshold for a slide root's speed.
        let stick_speed = 1e-9;
        let band = if f32_lanes { 1e-4 } else { 1e-12 };
        let accelerate = N > 1 && planes.iter().all(|p| p.friction() < 0.5);
        Self {
            mu: std::array::from_fn(|i| T::from_f64(planes[i].friction())),
            tangent: std::array::from_fn(|i| {
                let n = planes[i].normal();
                let t1 = n.any_orthonormal_vector();
                [t1, n.cross(t1)].map(|t| t.to_array().map(T::from_f64))
            }),
            grid: std::array::from_fn(|j| {
                let t = tau * (j % GRID) as f64 / GRID as f64;
                [t.cos(), t.sin(), (2.0 * t).cos(), (2.0 * t).sin()].map(T::from_f64)
            }),
            h: T::from_f64(h),
            half_h: T::from_f64(0.5 * h),
            take_off_band: T::from_f64(if f32_lanes { 1e-5 } else { 1e-12 }),
            stick_band: T::from_f64(band),
            slide_hi: T::from_f64(stick_speed + band),
            slide_lo: T::from_f64(stick_speed - band),
            round: T::from_f64(if f32_lanes { 1e-5 } else { 1e-12 }),
            angle_tol: T::from_f64(if f32_lanes { 1e-5 } else { 1e-12 }),
            gs_tol: T::from_f64(if f32_lanes { 2e-6 } else { 1e-13 }),
            // Only the lanes still sweeping pay for a long budget (they are
            // compacted): on the rough corner 64 sweeps left 4 % of f64
            // lanes to the reference, 256 leave 6e-5 and run 25 % faster.
            gs_max: 256,
            b3_bound: T::from_f64(2.0 * (1.0 - if f32_lanes { 1e-3 } else { 1e-9 })),
            certified_steps: if f32_lanes { 6 } else { 10 },
            accelerate,
            // Measured on the rough corner (newton, 2026-12-06, interleaved):
            // f32 lanes ran 7–19 % faster checking every 32 sweeps than
            // every 16 (48 as fast, 64 slower); f64 lanes as fast at 8 or
            // 16, 20 % slower at 32.
            accelerate_period: if f32_lanes { 32 } else { 16 },
            jump_tol: if f32_lanes { 1e-9 } else { JUMP_TOL },
        }
    }
}

/// The contact frames of a block: levers, pre-impact contact-point
/// velocities and Delassus blocks per touching plane. Cache-line aligned.
#[repr(C, align(64))]
pub struct Frame<T, const N: usize> {
    /// `lever[i][d][k]`: component k of `x_i × Aᵀd`, d = n, t₁, t₂.
    pub(super) lever: [[[[T; BLOCK]; 3]; 3]; N],
    /// `c0[i][d]`: `c⁻_i · d`.
    pub(super) c0: [[[T; BLOCK]; 3]; N],
    /// W_ii in the frame: nn, nt₁, nt₂, t₁t₁, t₁t₂, t₂t₂.
    pub(super) w: [[[T; BLOCK]; 6]; N],
    /// `|v| + L|ω|` before the impact.
    pub(super) vscale: [T; BLOCK],
    /// friction.md's certificate B3 per contact and lane (W and μ only, so
    /// it holds for every visit), and whether it holds in every lane.
    pub(super) b3: [[bool; BLOCK]; N],
    pub(super) b3_all: [bool; N],
}

/// Gauss–Seidel state of one law on a block.
#[repr(C, align(64))]
pub struct Sweep<T, const N: usize> {
    /// `p[i][d]`: contact i's impulse along d (N·s).
    pub(super) p: [[[T; BLOCK]; 3]; N],
    /// What the impulses have changed so far: v (world) and ω (body).
    pub(super) dv: [[T; BLOCK]; 3],
    pub(super) dw: [[T; BLOCK]; 3],
    /// The largest |ΔP_i| of the current sweep.
    pub(super) moved: [T; BLOCK],
    /// Stick bits per contact and [`UNSURE`].
    pub(super) bits: [u32; BLOCK],
    /// The current visit's single-contact solve.
    pub(super) solve: Solve<T>,
    /// `newton`'s lanes over its sweeps (taken out while they run).
    pub(super) queue: Option<Box<Queue<T, N>>>,
}

impl<T: Real, const N: usize> Frame<T, N> {
    pub fn new() -> Box<Self> {
        Box::new(Self {
            lever: [[[[T::ZERO; BLOCK]; 3]; 3]; N],
            c0: [[[T::ZERO; BLOCK]; 3]; N],
            w: [[[T::ZERO; BLOCK]; 6]; N],
            vscale: [T::ZERO; BLOCK],
            b3: [[false; BLOCK]; N],
            b3_all: [false; N],
        })
    }
}

impl<T: Real, const N: usize> Sweep<T, N> {
    pub fn new() -> Box<Self> {
        Box::new(Self {
            p: [[[T::ZERO; BLOCK]; 3]; N],
            dv: [[T::ZERO; BLOCK]; 3],
            dw: [[T::ZERO; BLOCK]; 3],
            moved: [T::ZERO; BLOCK],
            bits: [0; BLOCK],
            solve: Solve::empty(),
            queue: Some(Box::new(Queue::new())),
        })
    }
}

/// One contact's single-contact solve across a block, pass by pass (each
/// pass a loop over the lanes, so that it vectorises): the set-up with the
/// stick case, the grid intervals, the refinement of each root, the
/// choice. Cache-line aligned; one per worker.
#[repr(C, align(64))]
pub(super) struct Solve<T> {
    /// `a = c_n + b` of the free contact-point velocity, and its
    /// tangential part `c_t` (t₁, t₂).
    pub(super) a: [T; BLOCK],
    pub(super) ct: [[T; BLOCK]; 2],
    /// The stick case's impulse, and whether it is valid, or clearly not.
    pub(super) stick: [[T; BLOCK]; 3],
    pub(super) stick_ok: [bool; BLOCK],
    pub(super) stick_no: [bool; BLOCK],
    /// [`Slide`]'s coefficients: A0, A1, B1, A2, B2, N0.
    pub(super) coef: [[T; BLOCK]; 6],
    /// Bounds on |F‴|, |F⁗| and |F⁽⁵⁾|, and the margins of F (and N) and
    /// of D.
    pub(super) l3: [T; BLOCK],
    pub(super) l4: [T; BLOCK],
    pub(super) l5: [T; BLOCK],
    pub(super) m_f: [T; BLOCK],
    pub(super) m_d: [T; BLOCK],
    /// F, F′, F″, F‴, F⁗ at the current interval's left end.
    pub(super) left: [[T; BLOCK]; 5],
    /// Sign changes of F so far, and whether every interval was certified.
    pub(super) changes: [T; BLOCK],
    pub(super) grid_ok: [bool; BLOCK],
    /// Per sign change (at most four): the interval index j, F(θ_j),
    /// F(θ_j+1).
    pub(super) slot: [[[T; BLOCK]; 3]; 4],
    /// The refinement of the current root: cos θ_j, sin θ_j, t, lo, hi and
    /// the last step.
    pub(super) newton: [[T; BLOCK]; 6],
    /// Valid slide roots, the last one's direction, and whether every root
    /// was judged clear of the margins.
    pub(super) count: [T; BLOCK],
    pub(super) dir: [[T; BLOCK]; 2],
    pub(super) roots_ok: [bool; BLOCK],
    /// The visit's new impulse (n, t₁, t₂), whether it sticks, and whether
    /// every decision that chose it was clear of its margin.
    pub(super) new: [[T; BLOCK]; 3],
    pub(super) stuck: [bool; BLOCK],
    pub(super) sure: [bool; BLOCK],
    /// cos, sin of the certified search's start: the direction of
    /// `c_t + (−a/W_nn) w_t`, the sliding under the frictionless normal
    /// impulse (friction.md, after B3).
    pub(super) start: [[T; BLOCK]; 2],
    /// The lanes every pass runs over: the block, or after compaction its
    /// first `len` positions (a multiple of the vector width).
    pub(super) len: usize,
}

impl<T: Real> Solve<T> {
    pub(super) fn empty() -> Self {
        let z = [T::ZERO; BLOCK];
        Self {
            a: z,
            ct: [z; 2],
            stick: [z; 3],
            stick_ok: [false; BLOCK],
            stick_no: [false; BLOCK],
            coef: [z; 6],
            l3: z,
            l4: z,
            l5: z,
            m_f: z,
            m_d: z,
            left: [z; 5],
            changes: z,
            grid_ok: [false; BLOCK],
            slot: [[z; 3]; 4],
            newton: [z; 6],
            count: z,
            dir: [z; 2],
            roots_ok: [false; BLOCK],
            new: [z; 3],
            stuck: [false; BLOCK],
            sure: [false; BLOCK],
            start: [z; 2],
            len: BLOCK,
        }
    }
}

/// Lanes per vector of the widest lane type (f32 on AVX-512): the unit the
/// sweeping lanes are rounded up to.
pub(super) const WIDTH: usize = 16;

/// The block's lanes over its sweeps: where each is, and the iterate each
/// finished with.
#[repr(C, align(64))]
pub(super) struct Queue<T, const N: usize> {
    /// `lane[pos]`: the block lane now at position `pos`.
    pub(super) lane: [u16; BLOCK],
    /// Per block lane: done, and the iterate it was done with.
    pub(super) done: [bool; BLOCK],
    pub(super) p: [[[T; BLOCK]; 3]; N],
    pub(super) dv: [[T; BLOCK]; 3],
    pub(super) dw: [[T; BLOCK]; 3],
    pub(super) bits: [u32; BLOCK],
    /// The frame's B3-in-every-lane flags, which compaction narrows to the
    /// sweeping lanes.
    pub(super) b3_all: [bool; N],
    pub(super) moved_lanes: bool,
}

impl<T: Real, const N: usize> Queue<T, N> {
    pub(super) fn new() -> Self {
        let z = [T::ZERO; BLOCK];
        Self {
            lane: std::array::from_fn(|s| s as u16),
            done: [false; BLOCK],
            p: [[z; 3]; N],
            dv: [z; 3],
            dw: [z; 3],
            bits: [0; BLOCK],
            b3_all: [false; N],
            moved_lanes: false,
        }
    }
}
