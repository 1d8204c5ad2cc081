//! One statistic's summary: mean, interval, spread and quantiles, as the
//! run summary and its tables carry it.

use serde::{Deserialize, Serialize};

use crate::stats::{Moments, RatioOfSums, Stat};

/// Mean, spread and quantiles of one statistic. Quantiles are absent where
/// only moments are kept (statistics not listed in `[statistics]
/// quantiles`, paired differences).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct StatSummary {
    /// Values the statistic has.
    pub n: u64,
    /// Their mean (NaN without values).
    #[serde(deserialize_with = "nan_if_null")]
    pub mean: f64,
    /// The 95 % half-width of the mean (from the replicates under RQMC).
    #[serde(deserialize_with = "nan_if_null")]
    pub ci95: f64,
    /// Their standard deviation.
    #[serde(deserialize_with = "nan_if_null")]
    pub sd: f64,
    /// The smallest.
    #[serde(deserialize_with = "nan_if_null")]
    pub min: f64,
    /// The 1st percentile (with quantiles kept).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub p01: Option<f64>,
    /// The median (with quantiles kept).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub median: Option<f64>,
    /// The 99th percentile (with quantiles kept).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub p99: Option<f64>,
    /// The largest.
    #[serde(deserialize_with = "nan_if_null")]
    pub max: f64,
    /// RQMC only: what the replicates bought, the variance of this mean
    /// from independent samples over its variance from the replicates
    /// (null where either is zero or undefined).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gain: Option<f64>,
}

/// JSON writes a number that is not finite as null; it reads back as NaN.
pub(super) fn nan_if_null<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

impl StatSummary {
    /// The summary of moments alone (no quantiles).
    pub fn from_moments(m: &Moments) -> Self {
        let n = m.count();
        let nan_if_empty = |x: f64| if n == 0 { f64::NAN } else { x };
        Self {
            n,
            mean: nan_if_empty(m.mean()),
            ci95: m.ci95(),
            sd: nan_if_empty(m.sd()),
            min: nan_if_empty(m.min()),
            p01: None,
            median: None,
            p99: None,
            max: nan_if_empty(m.max()),
            gain: None,
        }
    }

    /// A ratio of sums: `n` pairs, `mean` the ratio, `ci95` its
    /// delta-method half-width, `sd` that of its linearised terms; `min`
    /// and `max` those of the per-pair ratios (`per_pair`), between which
    /// the ratio lies (it is their mean weighted by the denominators).
    /// `pilot` is the ratio its residuals were taken against.
    pub fn from_ratio(r: &RatioOfSums, pilot: f64, per_pair: &Moments) -> Self {
        let n = r.count();
        let nan_if_empty = |x: f64| if n == 0 { f64::NAN } else { x };
        Self {
            n,
            mean: r.ratio(pilot),
            ci95: r.ci95(pilot),
            sd: r.sd(pilot),
            min: nan_if_empty(per_pair.min()),
            p01: None,
            median: None,
            p99: None,
            max: nan_if_empty(per_pair.max()),
            gain: None,
        }
    }

    /// Every moment is a number (JSON writes an undefined one, as for an
    /// empty statistic or a ci95 of one value, as null).
    pub fn is_defined(&self) -> bool {
        [self.mean, self.ci95, self.sd, self.min, self.max]
            .iter()
            .all(|x| x.is_finite())
    }

    pub(super) fn from_stat(s: &Stat) -> Self {
        let mut out = Self::from_moments(&s.moments);
        // A statistic whose quantiles were not requested has no histogram.
        if out.n > 0 && s.hist.total() > 0 {
            out.p01 = Some(s.quantile(0.01));
            out.median = Some(s.quantile(0.5));
            out.p99 = Some(s.quantile(0.99));
        }
        out
    }
}

/// A 95 % interval `[low, high]` on a proportion: Wilson's score interval
/// of the count, or under RQMC the replicates' ([`crate::stats::proportion`]).
/// JSON: a two-element array, whose undefined ends (no samples) are null
/// and read back as NaN.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval(pub [f64; 2]);

impl Interval {
    /// Undefined: no samples.
    pub const NAN: Interval = Interval([f64::NAN, f64::NAN]);

    /// Wilson's interval of `k` in `n`.
    pub fn wilson(k: u64, n: u64) -> Self {
        Self(crate::stats::proportion::wilson(k, n))
    }

    /// The lower end.
    pub fn low(&self) -> f64 {
        self.0[0]
    }

    /// The upper end.
    pub fn high(&self) -> f64 {
        self.0[1]
    }

    /// Half its width.
    pub fn half_width(&self) -> f64 {
        0.5 * (self.0[1] - self.0[0])
    }
}

impl Serialize for Interval {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.0.serialize(s)
    }
}

impl<'de> Deserialize<'de> for Interval {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let [a, b] = <[Option<f64>; 2]>::deserialize(d)?;
        Ok(Self([a.unwrap_or(f64::NAN), b.unwrap_or(f64::NAN)]))
    }
}
