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
//! it is flagged [`Status::NEEDS_REFERENCE`] and solved by the f64 reference.
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
mod state;
mod sweeps;

pub use frames::frame;
pub use state::{Frame, FrictionConsts, Sweep};
pub use sweeps::friction_impulses;
