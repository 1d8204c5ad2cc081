//! friction.md's acceleration of `newton`'s Gauss–Seidel to the same limit,
//! for the lanes of a block (allowed where there are several contacts and
//! every μ < 0.5):
//! 1. every `period` sweeps from twice that, a lane whose contacts keep the
//!    cases (take-off, stick, slide) they had a period before, and whose
//!    largest move shrinks (`r = (s_t / s_{t−period})^{1/period} < 1`),
//! 2. solves that pattern's equations for all its contacts at once by
//!    Newton's method (in f64, [`pattern_newton`], the reference's own),
//! 3. and jumps there if the Newton point lies within `0.25 d` of the
//!    extrapolated point `P + ΔP r/(1 − r)` (`d = |ΔP| r/(1 − r)`).
//!
//! The next sweep of the block is the confirming sweep: a lane that meets
//! the stopping rule in it is done, with that sweep's iterate; any other
//! lane that jumped goes back to the iterate it jumped from and on with
//! plain Gauss–Seidel. The jump itself is scalar per lane: it happens a few
//! times per lane, and a sweep's visits stay in lanes. friction.md checks
//! every 4 sweeps; f64 lanes check every 16 and f32 lanes every 32,
//! because a jump costs a lane about as much as a few dozen of its sweeps
//! in lanes (measured on the rough corner: 4 gave 5.6·10⁴ samples/s in
//! f32, 16 gave 1.1·10⁵; with the jump's contacts off the heap, 32 runs
//! f32 7–19 % faster than 16, and 8 runs it 24–30 % slower). The limit
//! is the same: the confirming sweep decides.

use glam::{DMat3, DVec3};

use crate::kernel::friction::state::{Frame, Sweep, MOVED_SHIFT, STICK_SHIFT};
use crate::kernel::Consts;
use crate::lanes::dispatch::BLOCK;
use crate::lanes::Real;
use crate::physics::friction::{guard_passes, outer, pattern_newton, Case, Contacts};

/// A lane's iterate before a jump.
struct Saved<T, const N: usize> {
    lane: usize,
    p: [[T; 3]; N],
    dv: [T; 3],
    dw: [T; 3],
    bits: u32,
}

/// The acceleration's state over a block's sweeps.
pub(super) struct Acceleration<T, const N: usize> {
    /// Sweeps between checks (friction.md: 4), the first at twice that.
    period: u32,
    /// The impulses before the current sweep (taken before every fourth).
    before: Box<[[[T; BLOCK]; 3]; N]>,
    /// Per lane at the last check: its contacts' cases and largest move.
    cases: [[Case; N]; BLOCK],
    moved: [f64; BLOCK],
    /// The lanes that jumped after the last sweep.
    jumped: Vec<Saved<T, N>>,
}

impl<T: Real, const N: usize> Acceleration<T, N> {
    pub(super) fn new(period: u32) -> Self {
        Self {
            period,
            before: Box::new([[[T::ZERO; BLOCK]; 3]; N]),
            cases: [[Case::TakeOff; N]; BLOCK],
            moved: [f64::INFINITY; BLOCK],
            jumped: Vec::new(),
        }
    }

    /// A jump awaits its confirming sweep.
    pub(super) fn pending(&self) -> bool {
        !self.jumped.is_empty()
    }

    /// Moves the per-lane state with the lanes (see `compact`).
    pub(super) fn gather(
        &mut self,
        mut cases: impl FnMut(&mut [[Case; N]; BLOCK]),
        mut moved: impl FnMut(&mut [f64; BLOCK]),
    ) {
        cases(&mut self.cases);
        moved(&mut self.moved);
    }

    /// Before sweep `t` (from 1): the impulses, if `t` is a check.
    pub(super) fn before_sweep(&mut self, t: u32, sw: &Sweep<T, N>) {
        if t % self.period == 0 {
            *self.before = sw.p;
        }
    }

    /// After sweep `t`: undo the jumps it did not confirm, then, if `t` is
    /// a check, jump where the pattern allows. `unconverged`: the lanes
    /// that did not meet the stopping rule in sweep `t`.
    pub(super) fn after_sweep(
        &mut self,
        t: u32,
        c: &Consts<T, N>,
        fr: &Frame<T, N>,
        sw: &mut Sweep<T, N>,
        unconverged: &[bool; BLOCK],
    ) -> bool {
        let mut undone = false;
        for saved in self.jumped.drain(..) {
            let s = saved.lane;
            if !unconverged[s] {
                continue;
            }
            undone = true;
            for i in 0..N {
                for d in 0..3 {
                    sw.p[i][d][s] = saved.p[i][d];
                }
            }
            for m in 0..3 {
                sw.dv[m][s] = saved.dv[m];
                sw.dw[m][s] = saved.dw[m];
            }
            sw.bits[s] = saved.bits;
        }
        if t % self.period != 0 {
            return undone;
        }
        for s in 0..sw.solve.len.min(BLOCK) {
            if !unconverged[s] {
                continue;
            }
            let cases: [Case; N] = std::array::from_fn(|i| {
                if sw.p[i][0][s] == T::ZERO {
                    Case::TakeOff
                } else if c.fr.mu[i] == T::ZERO {
                    Case::Normal
                } else if sw.bits[s] & (1 << (STICK_SHIFT + i as u32)) != 0 {
                    Case::Stick
                } else {
                    Case::Slide
                }
            });
            let moved = sw.moved[s].to_f64();
            let (old_cases, old_moved) = (self.cases[s], self.moved[s]);
            self.cases[s] = cases;
            self.moved[s] = moved;
            if t < 2 * self.period || cases != old_cases || !(moved < old_moved) {
                continue;
            }
            if let Some(saved) = self.jump(
                s,
                c,
                fr,
                sw,
                &cases,
                (moved / old_moved).powf(1.0 / self.period as f64),
            ) {
                self.jumped.push(saved);
            }
        }
        undone
    }

    /// Lane `s`'s jump to its pattern's Newton point, if the guard allows
    /// it: the iterate it leaves.
    fn jump(
        &self,
        s: usize,
        c: &Consts<T, N>,
        fr: &Frame<T, N>,
        sw: &mut Sweep<T, N>,
        cases: &[Case; N],
        r: f64,
    ) -> Option<Saved<T, N>> {
        let f = |x: T| x.to_f64();
        let v3 = |x: [T; 3]| DVec3::new(f(x[0]), f(x[1]), f(x[2]));
        let dirs: [[DVec3; 3]; N] =
            std::array::from_fn(|i| [c.normal[i], c.fr.tangent[i][0], c.fr.tangent[i][1]].map(v3));
        let lever = |i: usize, d: usize| {
            DVec3::new(
                f(fr.lever[i][d][0][s]),
                f(fr.lever[i][d][1][s]),
                f(fr.lever[i][d][2][s]),
            )
        };
        let inv_j = v3(c.inv_inertia);
        let inv_m = f(c.inv_mass);
        let world = |i: usize, x: [f64; 3]| (0..3).fold(DVec3::ZERO, |a, d| a + dirs[i][d] * x[d]);
        // W_ij in the world frame, from its entries in the two contacts'
        // frames: d·e/m + Σ_k r_i,d,k r_j,e,k / J_k.
        // On the stack: no allocation per lane.
        let mut ct = Contacts::empty(N);
        for i in 0..N {
            for j in 0..N {
                let mut m = DMat3::ZERO;
                for d in 0..3 {
                    for e in 0..3 {
                        let x = dirs[i][d].dot(dirs[j][e]) * inv_m
                            + (lever(i, d) * lever(j, e)).dot(inv_j);
                        m += outer(dirs[i][d], dirs[j][e]) * x;
                    }
                }
                ct.w[i][j] = m;
            }
            ct.normals[i] = dirs[i][0];
            ct.mu[i] = f(c.fr.mu[i]);
            ct.k[i] = f(c.k[i]);
            ct.before[i] = world(i, std::array::from_fn(|d| f(fr.c0[i][d][s])));
        }
        ct.vscale = f(fr.vscale[s]);
        ct.pscale = f(c.mass) * ct.vscale;
        let p: [DVec3; N] =
            std::array::from_fn(|i| world(i, std::array::from_fn(|d| f(sw.p[i][d][s]))));
        let x = pattern_newton(&ct, &p, cases, false, c.fr.jump_tol)?;
        let previous: [DVec3; N] =
            std::array::from_fn(|i| world(i, std::array::from_fn(|d| f(self.before[i][d][s]))));
        if !guard_passes(&p, &previous, &x[..N], r) {
            return None;
        }
        let saved = Saved {
            lane: s,
            p: std::array::from_fn(|i| std::array::from_fn(|d| sw.p[i][d][s])),
            dv: std::array::from_fn(|m| sw.dv[m][s]),
            dw: std::array::from_fn(|m| sw.dw[m][s]),
            bits: sw.bits[s],
        };
        // The jump: the impulses in the contact frames, and what they do
        // to v and ω; every contact has moved.
        let (mut dv, mut dw) = (DVec3::ZERO, DVec3::ZERO);
        for i in 0..N {
            for d in 0..3 {
                let q = x[i].dot(dirs[i][d]);
                sw.p[i][d][s] = T::from_f64(q);
                dv += dirs[i][d] * (q * inv_m);
                dw += lever(i, d) * q * inv_j;
            }
        }
        for m in 0..3 {
            sw.dv[m][s] = T::from_f64(dv[m]);
            sw.dw[m][s] = T::from_f64(dw[m]);
        }
        sw.bits[s] |= ((1u32 << N) - 1) << MOVED_SHIFT;
        Some(saved)
    }
}
