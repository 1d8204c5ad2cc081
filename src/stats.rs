//! Mergeable accumulators: moments (shifted sums per batch, merged with
//! Chan's formula in a fixed order, so results are bit-identical for any
//! thread count), extrema, and log-linear histograms for quantiles.

/// Sub-bins per octave of [`LogHistogram`] (2^6 = 64: bins 1.1 % wide).
pub const SUB_BITS: u32 = 6;
/// Octaves covered: |x| in [2^MIN_EXP, 2^MAX_EXP); outside, values land in
/// the end bins (min and max stay exact).
pub const MIN_EXP: i32 = -32;
pub const MAX_EXP: i32 = 32;
const SUB: usize = 1 << SUB_BITS;
/// Bins per sign: a power of two, so a masked index is in range.
pub const BINS: usize = (MAX_EXP - MIN_EXP) as usize * SUB;
const _: () = assert!(BINS.is_power_of_two());

use crate::lanes::{Real, X16};

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
#[multiversion::multiversion(targets(
    "x86_64+avx512f+avx512bw+avx512cd+avx512dq+avx512vl+avx2+fma",
    "x86_64+avx2+fma",
))]
fn masked_sums<T: Real, const K: usize, const B: usize>(
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
            acc[k][2] = acc[k][2].min(X16::select_positive(wk, x, inf));
            acc[k][3] = acc[k][3].max(X16::select_positive(wk, x, ninf));
        }
    }
    (n, acc)
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
        let (mut n, mut acc) = masked_sums(xs, w, shift);
        for l in B / 16 * 16..B {
            if w[l] > T::ZERO {
                n.0[0] += T::ONE;
                for k in 0..K {
                    let d = xs[k][l] - shift[k];
                    let [s1, s2, lo, hi] = &mut acc[k];
                    s1.0[0] += d;
                    s2.0[0] += d * d;
                    lo.0[0] = lo.0[0].min(xs[k][l]);
                    hi.0[0] = hi.0[0].max(xs[k][l]);
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

/// Log-linear histogram of signed values: 64 bins per octave over
/// |x| ∈ [2^-32, 2^32), plus an exact-zero count. Both halves are
/// allocated on first use, so empty histograms cost nothing to merge.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LogHistogram {
    pos: Vec<u64>,
    neg: Vec<u64>,
    zero: u64,
}

#[inline(always)]
fn bin_of(mag: f64) -> usize {
    let bits = mag.to_bits();
    let exp = ((bits >> 52) & 0x7ff) as i32 - 1023;
    let sub = ((bits >> (52 - SUB_BITS)) & (SUB as u64 - 1)) as i32;
    ((exp - MIN_EXP) * SUB as i32 + sub).clamp(0, BINS as i32 - 1) as usize
}

/// `[lo, hi)` of bin `b` for magnitudes.
pub fn bin_edges(b: usize) -> (f64, f64) {
    let exp = (b / SUB) as i32 + MIN_EXP;
    let sub = (b % SUB) as f64;
    let base = 2f64.powi(exp);
    (
        base * (1.0 + sub / SUB as f64),
        base * (1.0 + (sub + 1.0) / SUB as f64),
    )
}

impl LogHistogram {
    /// Adds the values of `xs` with weight 1: bin indices in a vectorised
    /// pass ([`Self::bin_pass`]), then a scatter of increments; values ≤ 0
    /// are counted apart.
    #[inline(always)]
    pub fn push_weighted<T: Real, const B: usize>(&mut self, xs: &[T; B], w: &[T; B]) {
        if self.pos.is_empty() && !w.iter().any(|&x| x > T::ZERO) {
            return;
        }
        let mut idx = [0u16; B];
        let skipped = self.bin_pass(xs, w, &mut idx);
        scatter([self.positive_bins()], [&idx], [skipped]);
    }

    /// The vector part of [`Self::push_weighted`]: the bin of every counted
    /// positive value into `idx`, and bin 0 for every other lane, so that
    /// the scatter adds exactly 1 per lane ([`scatter`] then takes the
    /// returned number of other lanes off bin 0). Exact zeros are counted
    /// here and negatives (rare) pushed one by one.
    #[inline(always)]
    pub fn bin_pass<T: Real, const B: usize>(
        &mut self,
        xs: &[T; B],
        w: &[T; B],
        idx: &mut [u16; B],
    ) -> u32 {
        let mut skipped = 0u32;
        let mut other = false;
        for k in 0..B {
            let counted = w[k] > T::ZERO;
            let on = counted & (xs[k] > T::ZERO);
            idx[k] = if on { Self::bin_of(xs[k]) } else { 0 };
            skipped += !on as u32;
            other |= counted & !(xs[k] > T::ZERO);
        }
        if other {
            // Counted values ≤ 0: exact zeros by a compare-and-sum pass,
            // negatives (rare) one by one.
            let mut zeros = 0u32;
            let mut negative = false;
            for k in 0..B {
                zeros += ((w[k] > T::ZERO) & (xs[k] == T::ZERO)) as u32;
                negative |= (w[k] > T::ZERO) & (xs[k] < T::ZERO);
            }
            self.zero += zeros as u64;
            if negative {
                for k in 0..B {
                    if w[k] > T::ZERO && xs[k] < T::ZERO {
                        self.push(xs[k].to_f64());
                    }
                }
            }
        }
        skipped
    }

    /// The counts of positive values by bin (allocated on first use), for
    /// callers that scatter many increments: an index masked with
    /// `BINS − 1` needs no bounds check.
    #[inline(always)]
    pub fn positive_bins(&mut self) -> &mut [u64; BINS] {
        if self.pos.is_empty() {
            self.pos = vec![0; BINS];
        }
        (&mut self.pos[..]).try_into().expect("BINS counts")
    }

    /// Adds `n` copies of `x`.
    #[inline]
    pub fn push_repeated(&mut self, x: f64, n: u64) {
        if n == 0 {
            return;
        }
        if x > 0.0 {
            self.positive_bins()[bin_of(x)] += n;
        } else if x < 0.0 {
            if self.neg.is_empty() {
                self.neg = vec![0; BINS];
            }
            self.neg[bin_of(-x)] += n;
        } else {
            self.zero += n;
        }
    }

    /// Empties the histogram and keeps its tables (zeroed) for reuse: it
    /// then counts, merges and reports exactly as a new one.
    pub fn clear(&mut self) {
        self.pos.fill(0);
        self.neg.fill(0);
        self.zero = 0;
    }

    /// Adds `n` exact zeros.
    #[inline(always)]
    pub fn add_zeros(&mut self, n: u64) {
        self.zero += n;
    }

    /// Bin index of |x|, below [`BINS`].
    #[inline(always)]
    pub fn bin(x: f64) -> u16 {
        bin_of(x.abs()) as u16
    }

    /// [`Self::bin`] computed in the value's own precision (the same bin).
    #[inline(always)]
    pub fn bin_of<T: Real>(x: T) -> u16 {
        x.log_bin(SUB_BITS, MIN_EXP, BINS as i32)
    }

    #[inline]
    pub fn push(&mut self, x: f64) {
        if x > 0.0 {
            if self.pos.is_empty() {
                self.pos = vec![0; BINS];
            }
            self.pos[bin_of(x)] += 1;
        } else if x < 0.0 {
            if self.neg.is_empty() {
                self.neg = vec![0; BINS];
            }
            self.neg[bin_of(-x)] += 1;
        } else {
            self.zero += 1;
        }
    }

    pub fn merge(&mut self, o: &LogHistogram) {
        if !o.pos.is_empty() {
            if self.pos.is_empty() {
                self.pos = vec![0; BINS];
            }
            for (a, b) in self.pos.iter_mut().zip(&o.pos) {
                *a += b;
            }
        }
        if !o.neg.is_empty() {
            if self.neg.is_empty() {
                self.neg = vec![0; BINS];
            }
            for (a, b) in self.neg.iter_mut().zip(&o.neg) {
                *a += b;
            }
        }
        self.zero += o.zero;
    }

    /// Non-zero counts as `(sign, bin, count)`: sign 1 for positive values
    /// (bin from [`Self::bin`]), −1 for negative ones, 0 for exact zeros
    /// (bin 0). For shard files.
    pub fn entries(&self) -> Vec<(i8, u16, u64)> {
        let mut out = Vec::new();
        if self.zero > 0 {
            out.push((0, 0, self.zero));
        }
        for (sign, table) in [(1i8, &self.pos), (-1, &self.neg)] {
            for (b, &c) in table.iter().enumerate() {
                if c > 0 {
                    out.push((sign, b as u16, c));
                }
            }
        }
        out
    }

    /// Adds `count` to an entry of [`Self::entries`].
    pub fn add_entry(&mut self, sign: i8, bin: u16, count: u64) -> Result<(), String> {
        if bin as usize >= BINS {
            return Err(format!("histogram bin {bin} out of range (< {BINS})"));
        }
        match sign {
            0 => self.zero += count,
            1 => self.positive_bins()[bin as usize] += count,
            -1 => {
                if self.neg.is_empty() {
                    self.neg = vec![0; BINS];
                }
                self.neg[bin as usize] += count;
            }
            _ => return Err(format!("histogram sign {sign} is not -1, 0 or 1")),
        }
        Ok(())
    }

    pub fn total(&self) -> u64 {
        self.zero + self.pos.iter().sum::<u64>() + self.neg.iter().sum::<u64>()
    }

    /// Non-empty bins in ascending value order as `(lo, hi, count)`; the
    /// zero count is the bin `(0, 0)`.
    pub fn bins(&self) -> Vec<(f64, f64, u64)> {
        let mut out = Vec::new();
        for b in (0..self.neg.len()).rev() {
            if self.neg[b] > 0 {
                let (lo, hi) = bin_edges(b);
                out.push((-hi, -lo, self.neg[b]));
            }
        }
        if self.zero > 0 {
            out.push((0.0, 0.0, self.zero));
        }
        for b in 0..self.pos.len() {
            if self.pos[b] > 0 {
                let (lo, hi) = bin_edges(b);
                out.push((lo, hi, self.pos[b]));
            }
        }
        out
    }

    /// The p-quantile, linearly interpolated within its bin and clamped to
    /// the exact [min, max]. Relative error at most one bin width (1.1 %).
    pub fn quantile(&self, p: f64, min: f64, max: f64) -> f64 {
        let n = self.total();
        if n == 0 {
            return f64::NAN;
        }
        let target = p.clamp(0.0, 1.0) * n as f64;
        let mut below = 0.0;
        for (lo, hi, c) in self.bins() {
            let c = c as f64;
            if below + c >= target {
                let f = if c > 0.0 { (target - below) / c } else { 0.0 };
                return (lo + f * (hi - lo)).clamp(min, max);
            }
            below += c;
        }
        max
    }
}

/// Adds 1 to `tables[h][idx[h][k]]` for every lane k of every histogram h,
/// in one loop (the increments of different tables are independent, so
/// they overlap), then takes `skipped[h]` off bin 0 of each (the lanes
/// [`LogHistogram::bin_pass`] parked there).
#[inline(always)]
pub fn scatter<const H: usize, const B: usize>(
    tables: [&mut [u64; BINS]; H],
    idx: [&[u16; B]; H],
    skipped: [u32; H],
) {
    for k in 0..B {
        for h in 0..H {
            tables[h][idx[h][k] as usize & (BINS - 1)] += 1;
        }
    }
    for h in 0..H {
        tables[h][0] -= skipped[h] as u64;
    }
}

/// Moments with a histogram: everything the summary reports for a statistic.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Stat {
    pub moments: Moments,
    pub hist: LogHistogram,
}

impl Stat {
    #[inline(always)]
    pub fn push_weighted<T: Real, const B: usize>(&mut self, xs: &[T; B], w: &[T; B]) {
        self.moments.push_weighted(xs, w);
        self.hist.push_weighted(xs, w);
    }

    #[inline]
    pub fn push(&mut self, x: f64) {
        self.moments.push(x);
        self.hist.push(x);
    }
    pub fn flush(&mut self) {
        self.moments.flush();
    }
    /// Back to empty, keeping the histogram's tables ([`LogHistogram::clear`]).
    pub fn clear(&mut self) {
        self.moments = Moments::default();
        self.hist.clear();
    }
    pub fn merge(&mut self, o: &Stat) {
        self.moments.merge(&o.moments);
        self.hist.merge(&o.hist);
    }
    pub fn quantile(&self, p: f64) -> f64 {
        self.hist
            .quantile(p, self.moments.min(), self.moments.max())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bins_in_own_precision_match_the_f64_bins() {
        let mut x = 1e-12f64;
        while x < 1e12 {
            for v in [x, -x, x * 1.0001] {
                assert_eq!(LogHistogram::bin_of(v), LogHistogram::bin(v), "{v}");
                let f = v as f32;
                assert_eq!(LogHistogram::bin_of(f), LogHistogram::bin(f as f64), "{f}");
            }
            x *= 1.0137;
        }
        for f in [f32::MIN_POSITIVE, f32::MAX, 1e-45f32, 0.0, 1.0, 2.0] {
            assert_eq!(LogHistogram::bin_of(f), LogHistogram::bin(f as f64), "{f}");
        }
    }

    #[test]
    fn moments_match_two_pass_and_merge_in_any_batching() {
        let xs: Vec<f64> = (0..10_000)
            .map(|i| 1e6 + ((i * 7919) % 1000) as f64 * 0.001)
            .collect();
        let mean = xs.iter().sum::<f64>() / xs.len() as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (xs.len() - 1) as f64;
        let mut whole = Moments::default();
        for (c, chunk) in xs.chunks(777).enumerate() {
            let mut part = Moments::default();
            if c % 2 == 0 {
                for &x in chunk {
                    part.push(x);
                }
            } else {
                // The weighted block form, in blocks of 8 with a weight-0
                // filler value that must not count.
                for b in chunk.chunks(8) {
                    let mut xs = [-1e300f64; 8];
                    let mut w = [0f64; 8];
                    xs[..b.len()].copy_from_slice(b);
                    w[..b.len()].fill(1.0);
                    part.push_weighted(&xs, &w);
                }
            }
            part.flush();
            whole.merge(&part);
        }
        assert!((whole.mean() - mean).abs() < 1e-9);
        assert!((whole.sd() - var.sqrt()).abs() / var.sqrt() < 1e-9);
        assert_eq!(whole.count(), 10_000);
        assert_eq!(
            whole.min(),
            xs.iter().cloned().fold(f64::INFINITY, f64::min)
        );
    }

    /// Three statistics with shared weights in one pass get what each gets
    /// in a pass of its own, bit for bit (the shared count and the shifts
    /// are per statistic), including blocks without a weighted lane and a
    /// batch whose first block has none.
    #[test]
    fn fused_moments_are_the_separate_ones() {
        let mut fused: [Moments; 3] = Default::default();
        let mut single: [Moments; 3] = Default::default();
        for block in 0..40u32 {
            let xs: [[f32; 32]; 3] = std::array::from_fn(|k| {
                std::array::from_fn(|i| {
                    let t = (block * 32 + i as u32) as f32;
                    1e3 * k as f32 + (t * 0.7 + k as f32).sin() * (1.0 + k as f32)
                })
            });
            let w: [f32; 32] = std::array::from_fn(|i| {
                let on = block % 7 != 0 && (block as usize * 5 + i) % 3 != 0;
                if on {
                    1.0
                } else {
                    0.0
                }
            });
            let [f0, f1, f2] = &mut fused;
            Moments::push_weighted_many([f0, f1, f2], [&xs[0], &xs[1], &xs[2]], &w);
            for k in 0..3 {
                single[k].push_weighted(&xs[k], &w);
            }
            if block % 13 == 12 {
                for m in fused.iter_mut().chain(single.iter_mut()) {
                    m.flush();
                }
            }
        }
        assert_eq!(fused, single);
        assert!(fused[2].count() > 500, "{}", fused[2].count());
    }

    #[test]
    fn quantiles_within_one_bin() {
        let mut h = Stat::default();
        for i in 1..=100_000 {
            h.push(i as f64 / 1000.0); // uniform on (0, 100]
        }
        for (p, want) in [(0.01, 1.0), (0.5, 50.0), (0.99, 99.0)] {
            let got = h.quantile(p);
            assert!((got - want).abs() / want < 0.011, "p{p}: {got} vs {want}");
        }
        let mut s = Stat::default();
        s.push_weighted(&[-3.0, -1.0, 0.0, 2.0, 7.0], &[1.0, 1.0, 1.0, 1.0, 0.0]);
        assert_eq!(s.hist.total(), 4);
        assert!(s.quantile(0.1) < -1.0 && s.quantile(0.9) > 0.0);
    }
}
