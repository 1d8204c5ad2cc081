//! The slow lanes of `newton`'s Gauss–Seidel, compacted. A lane is done at
//! the first sweep that meets the stopping rule: its iterate is kept from
//! that sweep on (in the lane's own place), and it leaves the sweeps. The
//! lanes still sweeping are moved to the front of the block, so that the
//! passes run over as few vectors as hold them ([`Solve`]'s `len`, a
//! multiple of [`WIDTH`]). A lane's answer therefore does not depend on how
//! long the other lanes of its block take; at the end the frames go back to
//! their places and every lane's kept iterate to its own.
//!
//! [`Solve`]: crate::kernel::friction::slide::Solve

// Lane code indexes SoA arrays by lane and contact on purpose: the index
// form is what the loop vectoriser sees through.
#![allow(clippy::needless_range_loop)]

use super::accelerate::Acceleration;
use crate::kernel::friction::state::{Frame, Queue, Sweep, WIDTH};
use crate::lanes::dispatch::BLOCK;
use crate::lanes::Real;

/// `a[pos] = a[src[pos]]` for `pos < n`.
#[inline(always)]
fn gather<X: Copy>(a: &mut [X; BLOCK], src: &[u16; BLOCK], n: usize) {
    let old = *a;
    for pos in 0..n.min(BLOCK) {
        a[pos] = old[src[pos] as usize];
    }
}

/// `a[lane[pos]] = a[pos]` for every position: back to block order.
#[inline(always)]
fn scatter<X: Copy>(a: &mut [X; BLOCK], lane: &[u16; BLOCK]) {
    let old = *a;
    for pos in 0..BLOCK {
        a[lane[pos] as usize] = old[pos];
    }
}

impl<T: Real, const N: usize> Frame<T, N> {
    /// Every per-lane array of the frame, to move lanes around.
    fn each_lane(
        &mut self,
        mut real: impl FnMut(&mut [T; BLOCK]),
        mut flag: impl FnMut(&mut [bool; BLOCK]),
    ) {
        for i in 0..N {
            self.lever[i].iter_mut().flatten().for_each(&mut real);
            self.c0[i].iter_mut().for_each(&mut real);
            self.w[i].iter_mut().for_each(&mut real);
            flag(&mut self.b3[i]);
        }
        real(&mut self.vscale);
    }
}

impl<T: Real, const N: usize> Queue<T, N> {
    /// Before the first sweep: every lane in its place, none done.
    pub(super) fn start(&mut self, fr: &Frame<T, N>) {
        self.lane = std::array::from_fn(|s| s as u16);
        self.done = [false; BLOCK];
        self.b3_all = fr.b3_all;
        self.moved_lanes = false;
    }

    /// After a sweep (and the acceleration's undoing of unconfirmed
    /// jumps): the lanes that met the stopping rule for the first time keep
    /// this iterate.
    pub(super) fn settle(&mut self, sw: &Sweep<T, N>, unconverged: &[bool; BLOCK]) {
        for pos in 0..sw.solve.len.min(BLOCK) {
            let l = self.lane[pos] as usize;
            if unconverged[pos] || self.done[l] {
                continue;
            }
            self.done[l] = true;
            self.keep(sw, pos, l);
        }
    }

    fn keep(&mut self, sw: &Sweep<T, N>, pos: usize, l: usize) {
        for i in 0..N {
            for d in 0..3 {
                self.p[i][d][l] = sw.p[i][d][pos];
            }
        }
        for m in 0..3 {
            self.dv[m][l] = sw.dv[m][pos];
            self.dw[m][l] = sw.dw[m][pos];
        }
        self.bits[l] = sw.bits[pos];
    }

    /// Moves the lanes still sweeping to the front when that frees at least
    /// one vector (not while a jump awaits its confirming sweep).
    pub(super) fn compact(
        &mut self,
        fr: &mut Frame<T, N>,
        sw: &mut Sweep<T, N>,
        acc: Option<&mut Acceleration<T, N>>,
        unconverged: &mut [bool; BLOCK],
    ) {
        if acc.as_ref().is_some_and(|a| a.pending()) {
            return;
        }
        let len = sw.solve.len.min(BLOCK);
        let active = unconverged[..len].iter().filter(|&&u| u).count();
        let new_len = active.div_ceil(WIDTH) * WIDTH;
        if new_len >= len {
            return;
        }
        // The sweeping lanes first, in order, then the rest.
        let mut src = [0u16; BLOCK];
        let mut front = 0;
        let mut back = active;
        for pos in 0..len {
            let slot = if unconverged[pos] {
                &mut front
            } else {
                &mut back
            };
            src[*slot] = pos as u16;
            *slot += 1;
        }
        fr.each_lane(|a| gather(a, &src, len), |a| gather(a, &src, len));
        for i in 0..N {
            for d in 0..3 {
                gather(&mut sw.p[i][d], &src, len);
            }
        }
        for m in 0..3 {
            gather(&mut sw.dv[m], &src, len);
            gather(&mut sw.dw[m], &src, len);
        }
        gather(&mut sw.bits, &src, len);
        gather(&mut self.lane, &src, len);
        gather(unconverged, &src, len);
        if let Some(a) = acc {
            a.gather(|x| gather(x, &src, len), |x| gather(x, &src, len));
        }
        for i in 0..N {
            fr.b3_all[i] = fr.b3[i][..new_len].iter().all(|&b| b);
        }
        sw.solve.len = new_len;
        self.moved_lanes = true;
    }

    /// After the last sweep: the lanes not done keep their last iterate and
    /// are the unconverged ones; the frame and every lane's iterate go back
    /// to block order.
    pub(super) fn finish(
        &mut self,
        fr: &mut Frame<T, N>,
        sw: &mut Sweep<T, N>,
        unconverged: &mut [bool; BLOCK],
    ) {
        for pos in 0..sw.solve.len.min(BLOCK) {
            let l = self.lane[pos] as usize;
            if !self.done[l] {
                self.keep(sw, pos, l);
            }
        }
        for l in 0..BLOCK {
            unconverged[l] = !self.done[l];
        }
        if self.moved_lanes {
            let lane = self.lane;
            fr.each_lane(|a| scatter(a, &lane), |a| scatter(a, &lane));
            fr.b3_all = self.b3_all;
        }
        sw.p = self.p;
        sw.dv = self.dv;
        sw.dw = self.dw;
        sw.bits = self.bits;
        sw.solve.len = BLOCK;
    }
}
