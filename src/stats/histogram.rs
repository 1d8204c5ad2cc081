//! Log-linear histograms of signed values, for quantiles.

use crate::lanes::Real;

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
