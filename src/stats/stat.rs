//! A statistic with quantiles: its moments and its log-linear histogram,
//! pushed and merged together.

use crate::lanes::Real;
use crate::stats::{LogHistogram, Moments};

/// Moments and a histogram of one quantity.
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
