//! Coulomb friction in lanes (friction.md): each touching plane's contact
//! frame, the single-contact solve (take-off, stick, slide) with a
//! certificate, and the laws `newton` (Gauss–Seidel to its limit), `pgsN`
//! and `paper` as visits of it.
//!
//! Contact i has three directions d ∈ {n, t₁, t₂} (its normal and a tangent
//! basis fixed per plane, in the world frame) and for each the body-frame
//! lever `r = x_i × Aᵀd`. The contact-point velocity along d is
//! `c_d = d·v + r·ω`; impulse components `P_d` change v by `Σ P_d d / m`
//! and ω by `J⁻¹ Σ P_d r`. The Delassus block in these coordinates is
//! `W_de = δ_de/m + Σ_k r_d,k r_e,k / J_k` (friction.md, "Kinematics").
//!
//! The slide angle θ of `ŝ = cos θ t₁ + sin θ t₂` solves
//! `F(θ) = ŝ⊥·[D(θ) c_t − a (w_t − μ W_tt ŝ)] = 0` (friction.md, case 3), a
//! trigonometric polynomial of degree 2 with closed-form coefficients
//! ([`Slide`]), so it has at most four roots. They are located on a fixed
//! grid of 32 intervals: each interval must be certified root-free, or to
//! hold exactly one root (F monotone there, or convex or concave with a
//! sign change), from F and its derivatives at the interval's ends and a
//! bound on the next derivative ([`positive_on`]). Each root is refined by
//! a fixed count of safeguarded Newton steps in its interval and judged
//! where it is: valid when D > 0 and its sliding speed N/D exceeds the stick
//! threshold, both clear of the margins. A lane is solved here only when
//! exactly one valid case remains (stick, or one slide root) and every
//! decision on the way is clear of its boundary by a margin above the lane
//! type's rounding; otherwise (several valid cases: `ambiguous`; none:
//! `unsolved`; a decision within its margin; Gauss–Seidel not converged)
//! it is flagged [`RECOMPUTE`] and solved by the f64 reference.
//!
//! `newton` with several contacts sweeps each lane to its own stopping
//! rule; the lanes still sweeping are moved to the front of the block, so
//! that the passes run over as few vectors as hold them (`compact`).
//!
//! Each step is a pass over the lanes of a block with its state in
//! [`Solve`], so that every loop vectorises; the passes run inside the
//! multiversioned entry points of `engine/batch.rs`, whose reference
//! arguments tell the compiler the arrays do not overlap.

// Lane code indexes SoA arrays by lane and contact on purpose: the index
// form is what the loop vectoriser sees through.
#![allow(clippy::needless_range_loop, clippy::manual_memcpy)]

mod accelerate;
mod compact;
mod frames;
mod post;
mod slide;
mod sweeps;

use crate::config::Scene;
use crate::lanes::dispatch::BLOCK;
use crate::lanes::Real;

use crate::kernel::friction::compact::Queue;
use crate::kernel::friction::slide::Solve;
pub use frames::frame;
pub use sweeps::friction_impulses;

/// Intervals of the slide angle's grid over [0, 2π).
const GRID: usize = 32;

/// Contact i's last visit took the stick case (bit `STICK_SHIFT + i` of
/// the sweep bits).
const STICK_SHIFT: u32 = 0;
/// Some visit of the lane could not be certified.
const UNSURE: u32 = 1 << 8;
/// Contact i's velocity changed after its last visit (bit
/// `MOVED_SHIFT + i`): another contact's impulse moved since.
const MOVED_SHIFT: u32 = 12;

/// The friction constants of a scene for the lane kernel.
#[derive(Debug, Clone)]
pub struct FrictionConsts<T, const N: usize> {
    mu: [T; N],
    /// t₁, t₂ of each touching plane (world): the tangent basis the
    /// reference uses, though no result depends on it.
    tangent: [[[T; 3]; 2]; N],
    /// cos θ_j, sin θ_j, cos 2θ_j, sin 2θ_j at θ_j = 2πj/GRID, j ≤ GRID.
    grid: [[T; 4]; GRID + 1],
    /// The grid step 2π/GRID and half of it.
    h: T,
    half_h: T,
    /// Decisions closer than these to their boundary are not taken here:
    /// `take_off_band`, |a| against 0 and a contact's final sliding speed
    /// against friction.md's stick threshold, relative to the velocity
    /// scale; `stick_band`, |f| against μλ in the stick test, relative;
    /// `slide_hi` and `slide_lo`, a slide root's speed above and below the
    /// threshold, relative to the velocity scale; `round`, the
    /// certificate's values, relative to their terms' magnitude.
    take_off_band: T,
    stick_band: T,
    slide_hi: T,
    slide_lo: T,
    round: T,
    /// The refined angle's last Newton step must be below this (rad).
    angle_tol: T,
    /// Gauss–Seidel's stopping rule: no impulse moved by more than this
    /// times `m (|v| + L|ω|)` in a sweep (friction.md: 1e-13 in f64).
    gs_tol: T,
    /// Sweeps after which a block's unconverged lanes go to the reference.
    gs_max: u32,
    /// B3's bound, 2 less a margin for the lane type's rounding.
    b3_bound: T,
    /// Newton steps from the certified start direction.
    certified_steps: u32,
    /// friction.md's acceleration of `newton`'s Gauss–Seidel: several
    /// contacts, every μ < 0.5.
    accelerate: bool,
    /// Sweeps between its checks.
    accelerate_period: u32,
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
            accelerate_period: 16,
        }
    }
}

/// The contact frames of a block: levers, pre-impact contact-point
/// velocities and Delassus blocks per touching plane. Cache-line aligned.
#[repr(C, align(64))]
pub struct Frame<T, const N: usize> {
    /// `lever[i][d][k]`: component k of `x_i × Aᵀd`, d = n, t₁, t₂.
    lever: [[[[T; BLOCK]; 3]; 3]; N],
    /// `c0[i][d]`: `c⁻_i · d`.
    c0: [[[T; BLOCK]; 3]; N],
    /// W_ii in the frame: nn, nt₁, nt₂, t₁t₁, t₁t₂, t₂t₂.
    w: [[[T; BLOCK]; 6]; N],
    /// `|v| + L|ω|` before the impact.
    vscale: [T; BLOCK],
    /// friction.md's certificate B3 per contact and lane (W and μ only, so
    /// it holds for every visit), and whether it holds in every lane.
    b3: [[bool; BLOCK]; N],
    b3_all: [bool; N],
}

/// Gauss–Seidel state of one law on a block.
#[repr(C, align(64))]
pub struct Sweep<T, const N: usize> {
    /// `p[i][d]`: contact i's impulse along d (N·s).
    p: [[[T; BLOCK]; 3]; N],
    /// What the impulses have changed so far: v (world) and ω (body).
    dv: [[T; BLOCK]; 3],
    dw: [[T; BLOCK]; 3],
    /// The largest |ΔP_i| of the current sweep.
    moved: [T; BLOCK],
    /// Stick bits per contact and [`UNSURE`].
    bits: [u32; BLOCK],
    /// The current visit's single-contact solve.
    solve: Solve<T>,
    /// `newton`'s lanes over its sweeps (taken out while they run).
    queue: Option<Box<Queue<T, N>>>,
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
