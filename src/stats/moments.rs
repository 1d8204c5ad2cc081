//! Moments: shifted sums per batch, merged with Chan's formula in a fixed
//! order (so results are bit-identical for any thread count), and extrema.

use crate::lanes::dispatch::multiversioned;
use crate::lanes::{Real, X16};

multiversioned! {
    /// Sixteen-lane partial sums of a block for K statistics that share their
    /// weights, in the values' own precision: weight, then per statistic the
    /// shifted sum, shifted sum of squares, min and max of the weighted values,
    /// over the block's first `16·⌊B/16⌋` lanes (the caller adds the rest). The
    /// weights are loaded and summed once. A function of its own, compiled per
    /// target: inlined into a large caller, LLVM scalarises part of it.
    ///
    /// In f32 (the f32 kernel's statistics) a block's sums are over at most a
    /// few hundred values, shifted by the batch's first value, so their
    /// rounding (≲ 10⁻⁵ relative to the block's spread) is far below the Monte
    /// Carlo error; blocks are then combined in f64.
    fn masked_sums<T: Real, const K: usize, const B: usize, const EXTREMA: bool>(
        xs: [&[T; B]; K],
        w: &[T; B],
        shift: [T; K],
    ) -> (X16<T>, [[X16<T>; 4]; K]) {
        let (inf, ninf) = (X16::splat(T::INFINITY), X16::splat(T::NEG_INFINITY));
        let zero = X16::splat(T::ZERO);
        let mut n = zero;
        let mut acc = [[zero, zero, inf, ninf]; K];
        for c in 0..B / 16 {
            let wk = X16::load(w, c);
            n = n + wk;
            for k in 0..K {
                let x = X16::load(xs[k], c);
                let d = (x - X16::splat(shift[k])) * wk;
                acc[k][0] = acc[k][0] + d;
                acc[k][1] = acc[k][1] + d * d;
                if EXTREMA {
                    acc[k][2] = acc[k][2].min(X16::select_positive(wk, x, inf));
                    acc[k][3] = acc[k][3].max(X16::select_positive(wk, x, ninf));
                }
            }
        }
        (n, acc)
    }
}

/// Count, mean, variance, min and max.
///
/// `push` adds to per-batch sums shifted by the batch's first value; `flush`
/// folds them into the merged (n, mean, M2) with Chan's pairwise formula.
#[derive(Debug, Clone, PartialEq)]
pub struct Moments {
    n: u64,
    mean: f64,
    m2: f64,
    min: f64,
    max: f64,
    pending_n: u64,
    shift: f64,
    /// Pending shifted sums, per lane of the 16-lane block sums (folded in
    /// lane order by `flush`): adding a block's sums is then one vector
    /// addition, not a chain of sixteen.
    s1: X16<f64>,
    s2: X16<f64>,
}

impl Default for Moments {
    fn default() -> Self {
        Self {
            n: 0,
            mean: 0.0,
            m2: 0.0,
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
            pending_n: 0,
            shift: 0.0,
            s1: X16::splat(0.0),
            s2: X16::splat(0.0),
        }
    }
}

impl Moments {
    #[inline]
    pub fn push(&mut self, x: f64) {
        if self.pending_n == 0 {
            self.shift = x;
        }
        self.pending_n += 1;
        let d = x - self.shift;
        self.s1.0[0] += d;
        self.s2.0[0] += d * d;
        self.min = self.min.min(x);
        self.max = self.max.max(x);
    }

    /// Adds `n` copies of `x` (a statistic that is the same in every
    /// sample): what `n` calls of [`Self::push`] would add, up to rounding.
    #[inline]
    pub fn push_repeated(&mut self, x: f64, n: u64) {
        if n == 0 {
            return;
        }
        if self.pending_n == 0 {
            self.shift = x;
        }
        self.pending_n += n;
        let d = x - self.shift;
        self.s1.0[0] += n as f64 * d;
        self.s2.0[0] += n as f64 * d * d;
        self.min = self.min.min(x);
        self.max = self.max.max(x);
    }

    /// Adds the values of `xs` with weight 1 in `w` (weights are 0 or 1;
    /// every `xs` must be finite). The sums run in sixteen fixed partial
    /// accumulators, so the loop vectorises and the order of additions is
    /// fixed.
    #[inline(always)]
    pub fn push_weighted<T: Real, const B: usize>(&mut self, xs: &[T; B], w: &[T; B]) {
        Self::push_weighted_many([self], [xs], w);
    }

    /// [`Self::push_weighted`] for K statistics with the same weights, in
    /// one pass over the block (each gets the sums it would get alone).
    #[inline(always)]
    pub fn push_weighted_many<T: Real, const K: usize, const B: usize>(
        ms: [&mut Moments; K],
        xs: [&[T; B]; K],
        w: &[T; B],
    ) {
        Self::push_weighted_many_with::<T, K, B, true>(ms, xs, w);
    }

    /// [`Self::push_weighted_many`] without the extrema (they stay ±∞):
    /// for moments that only feed a combined statistic (a ratio of sums),
    /// at about half the cost of the pass.
    #[inline(always)]
    pub fn push_weighted_sums_many<T: Real, const K: usize, const B: usize>(
        ms: [&mut Moments; K],
        xs: [&[T; B]; K],
        w: &[T; B],
    ) {
        Self::push_weighted_many_with::<T, K, B, false>(ms, xs, w);
    }

    #[inline(always)]
    fn push_weighted_many_with<T: Real, const K: usize, const B: usize, const EXTREMA: bool>(
        ms: [&mut Moments; K],
        xs: [&[T; B]; K],
        w: &[T; B],
    ) {
        let Some(first) = w.iter().position(|&m| m > T::ZERO) else {
            return;
        };
        let mut ms = ms;
        let mut shift = [T::ZERO; K];
        for k in 0..K {
            if ms[k].pending_n == 0 {
                ms[k].shift = xs[k][first].to_f64();
            }
            shift[k] = T::from_f64(ms[k].shift);
        }
        // The shift is a value of the stream, so exact in its type.
        let (mut n, mut acc) = masked_sums::<T, K, B, EXTREMA>(xs, w, shift);
        for l in B / 16 * 16..B {
            if w[l] > T::ZERO {
                n.0[0] += T::ONE;
                for k in 0..K {
                    let d = xs[k][l] - shift[k];
                    let [s1, s2, lo, hi] = &mut acc[k];
                    s1.0[0] += d;
                    s2.0[0] += d * d;
                    if EXTREMA {
                        lo.0[0] = lo.0[0].min(xs[k][l]);
                        hi.0[0] = hi.0[0].max(xs[k][l]);
                    }
                }
            }
        }
        // Counts are exact small integers and extrema are order-free, so
        // tree reductions; the sums stay per lane.
        let n = n.tree_sum().to_f64() as u64;
        for (m, [s1, s2, lo, hi]) in ms.iter_mut().zip(acc) {
            m.pending_n += n;
            m.s1 = m.s1 + s1.to_f64();
            m.s2 = m.s2 + s2.to_f64();
            m.min = m.min.min(lo.tree_min().to_f64());
            m.max = m.max.max(hi.tree_max().to_f64());
        }
    }

    /// Folds the pending batch sums into the merged moments.
    pub fn flush(&mut self) {
        if self.pending_n == 0 {
            return;
        }
        let nb = self.pending_n as f64;
        let (mut s1, mut s2) = (0.0, 0.0);
        for j in 0..16 {
            s1 += self.s1.0[j];
            s2 += self.s2.0[j];
        }
        let mean_b = self.shift + s1 / nb;
        let m2_b = (s2 - s1 * s1 / nb).max(0.0);
        self.combine(self.pending_n, mean_b, m2_b);
        self.pending_n = 0;
        self.s1 = X16::splat(0.0);
        self.s2 = X16::splat(0.0);
    }

    fn combine(&mut self, nb: u64, mean_b: f64, m2_b: f64) {
        if nb == 0 {
            return;
        }
        if self.n == 0 {
            self.n = nb;
            self.mean = mean_b;
            self.m2 = m2_b;
            return;
        }
        let na = self.n as f64;
        let nbf = nb as f64;
        let n = na + nbf;
        let delta = mean_b - self.mean;
        self.mean += delta * nbf / n;
        self.m2 += m2_b + delta * delta * na * nbf / n;
        self.n += nb;
    }

    /// Merges `other` (after both are flushed) into `self`.
    pub fn merge(&mut self, other: &Moments) {
        let mut o = other.clone();
        o.flush();
        self.flush();
        self.combine(o.n, o.mean, o.m2);
        self.min = self.min.min(o.min);
        self.max = self.max.max(o.max);
    }

    /// The merged state `(n, mean, M2, min, max)`, for shard files. Pending
    /// sums are folded first.
    pub fn state(&self) -> (u64, f64, f64, f64, f64) {
        let (n, mean, m2) = self.merged();
        (n, mean, m2, self.min, self.max)
    }

    /// The inverse of [`Self::state`]: bit-exact, so a restored accumulator
    /// merges exactly as the original would.
    pub fn from_state(n: u64, mean: f64, m2: f64, min: f64, max: f64) -> Self {
        Self {
            n,
            mean,
            m2,
            min,
            max,
            ..Self::default()
        }
    }

    pub fn count(&self) -> u64 {
        self.n + self.pending_n
    }
    /// The sum of the values (of the weighted values, weight 1), pending
    /// sums included, without folding them: what the cluster sums of
    /// [`crate::stats::clusters`] take the differences of.
    pub fn sum(&self) -> f64 {
        let pending: f64 = self.s1.0.iter().sum();
        self.n as f64 * self.mean + self.pending_n as f64 * self.shift + pending
    }
    pub fn mean(&self) -> f64 {
        self.merged().1
    }
    /// Sample standard deviation (n − 1 in the denominator).
    pub fn sd(&self) -> f64 {
        let (n, _, m2) = self.merged();
        if n < 2 {
            0.0
        } else {
            (m2 / (n - 1) as f64).sqrt()
        }
    }
    /// Half-width of the normal-approximation 95 % confidence interval of
    /// the mean, `1.96 sd / √n`.
    pub fn ci95(&self) -> f64 {
        let n = self.count();
        if n < 2 {
            f64::NAN
        } else {
            1.96 * self.sd() / (n as f64).sqrt()
        }
    }
    pub fn min(&self) -> f64 {
        self.min
    }
    pub fn max(&self) -> f64 {
        self.max
    }

    fn merged(&self) -> (u64, f64, f64) {
        let mut c = self.clone();
        c.flush();
        (c.n, c.mean, c.m2)
    }
}

/// A ratio of sums `R = Σx / Σy` over pairs with `y > 0`, with the error of
/// a ratio estimator (delta method): `ci95 = 1.96 · sd(z) / √n` with
/// `z = (x − R·y) / ȳ`.
///
/// It keeps the moments of the residual `r = x − e₀·y` against a pilot
/// ratio `e₀` (a run constant the caller passes back: a plane's
/// restitution), of `y` and of `r + y` (which give the covariance). Where
/// the ratio is near the pilot, as under Newton's law where every pair has
/// it up to rounding, var z is then var r itself, not the difference of
/// two nearly equal variances of x and y (which cancelled to 0 in f32).
/// Mergeable like its moments.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RatioOfSums {
    pub resid: Moments,
    pub y: Moments,
    pub sum: Moments,
}

impl RatioOfSums {
    /// Adds the pair `(x, y)`, its residual taken against `pilot`.
    pub fn push(&mut self, x: f64, y: f64, pilot: f64) {
        let r = x - pilot * y;
        self.resid.push(r);
        self.y.push(y);
        self.sum.push(r + y);
    }

    pub fn count(&self) -> u64 {
        self.y.count()
    }

    /// `Σx / Σy = e₀ + Σr / Σy` (NaN with no pair).
    pub fn ratio(&self, pilot: f64) -> f64 {
        if self.count() == 0 {
            return f64::NAN;
        }
        pilot + self.resid.mean() / self.y.mean()
    }

    /// The standard deviation of `z = (x − R·y)/ȳ = (r − (R − e₀)·y)/ȳ`:
    /// `√(var r − 2δ cov(r, y) + δ² var y) / ȳ` with `δ = R − e₀`.
    pub fn sd(&self, pilot: f64) -> f64 {
        if self.count() < 2 {
            return f64::NAN;
        }
        let (vr, vy, vs) = (
            self.resid.sd().powi(2),
            self.y.sd().powi(2),
            self.sum.sd().powi(2),
        );
        let cov = 0.5 * (vs - vr - vy);
        let delta = self.ratio(pilot) - pilot;
        (vr - 2.0 * delta * cov + delta * delta * vy)
            .max(0.0)
            .sqrt()
            / self.y.mean()
    }

    pub fn ci95(&self, pilot: f64) -> f64 {
        let n = self.count();
        if n < 2 {
            f64::NAN
        } else {
            1.96 * self.sd(pilot) / (n as f64).sqrt()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The ratio, and sd(z) against a two-pass computation over the pairs
    /// (z = (x − R·y)/ȳ), for a ratio that varies and one that is the
    /// pilot up to rounding (x = e·y·(1 + δ), |δ| ≤ 6e-8, as in f32):
    /// there the old form, var x − 2R cov + R² var y from the moments of
    /// x, y and x + y, cancelled to about 0.
    #[test]
    fn ratio_of_sums_against_two_passes() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut uniform = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let e = 0.8;
        for spread in [0.2, 6e-8] {
            let pairs: Vec<(f64, f64)> = (0..20_000)
                .map(|_| {
                    let y = 0.1 + 3.0 * uniform();
                    (e * y * (1.0 + spread * (2.0 * uniform() - 1.0)), y)
                })
                .collect();
            let mut r = RatioOfSums::default();
            for &(x, y) in &pairs {
                r.push(x, y, e);
            }
            r.resid.flush();
            r.y.flush();
            r.sum.flush();
            let n = pairs.len() as f64;
            let (sx, sy) = pairs.iter().fold((0.0, 0.0), |a, p| (a.0 + p.0, a.1 + p.1));
            let ratio = sx / sy;
            let ybar = sy / n;
            let z: Vec<f64> = pairs.iter().map(|&(x, y)| (x - ratio * y) / ybar).collect();
            let zbar = z.iter().sum::<f64>() / n;
            let sd = (z.iter().map(|v| (v - zbar).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
            assert!(
                (r.ratio(e) - ratio).abs() < 1e-14,
                "{spread}: {}",
                r.ratio(e)
            );
            assert!(
                (r.sd(e) - sd).abs() < 1e-6 * sd,
                "{spread}: sd {} vs {sd}",
                r.sd(e)
            );
            assert!(sd > 0.0);
        }
    }
}
