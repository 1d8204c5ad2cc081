//! Branch-free special functions in f64 lanes for the flights' set-up:
//! `exp`, Carlson's R_F and the arithmetic–geometric mean, each with a
//! fixed step count that is enough for f64 (no data-dependent loop).

use crate::lanes::select;

/// Steps of the AGM for K′: from √m ≥ 1e-7 it has converged to f64 within
/// eight; two more are margin (a converged AGM stays put).
pub const AGM_STEPS: usize = 10;

/// Carlson duplications for R_F before its sixth-order series: from
/// arguments as far apart as 0, 1e-14 and 1 the result is f64's own after
/// eight (each duplication divides the spread by about four, the series
/// takes the rest); two more are margin.
pub const RF_STEPS: usize = 10;

/// `e^x` for x ≤ 709 (zero below −708): x = k ln 2 + r with |r| ≤ ½ ln 2,
/// e^r by its Taylor series to degree 13, 2^k from the exponent bits.
#[inline(always)]
pub fn exp(x: f64) -> f64 {
    const LN2_HI: f64 = 6.931_471_803_691_238e-1;
    const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
    let tiny = x < -708.0;
    let x = x.clamp(-708.0, 709.0);
    let k = (x * std::f64::consts::LOG2_E).round_ties_even();
    let r = k.mul_add(-LN2_LO, k.mul_add(-LN2_HI, x));
    let mut p: f64 = 1.0 / 6_227_020_800.0;
    for n in (1..13).rev() {
        p = p.mul_add(r, 1.0 / FACTORIAL[n]);
    }
    let scale = f64::from_bits(((k as i64 + 1023) as u64) << 52);
    select(tiny, 0.0, p.mul_add(r, 1.0) * scale)
}

/// n! for n < 13.
const FACTORIAL: [f64; 13] = [
    1.0,
    1.0,
    2.0,
    6.0,
    24.0,
    120.0,
    720.0,
    5040.0,
    40320.0,
    362_880.0,
    3_628_800.0,
    39_916_800.0,
    479_001_600.0,
];

/// Carlson's R_F(x, y, z) by [`RF_STEPS`] duplications and its sixth-order
/// series (as [`crate::physics::carlson_rf`], which stops once the
/// arguments are within 0.0025 of their mean).
/// (The set-up runs the same steps inline, lane by lane; this form is what
/// the tests check them against.)
#[cfg(test)]
pub fn rf(x: f64, y: f64, z: f64) -> f64 {
    let mut xyz = [x, y, z];
    for _ in 0..RF_STEPS {
        xyz = duplicate(xyz);
    }
    crate::physics::carlson_rf_series(xyz[0], xyz[1], xyz[2])
}

/// One of Carlson's duplications.
#[inline(always)]
pub(super) fn duplicate([x, y, z]: [f64; 3]) -> [f64; 3] {
    let (sx, sy, sz) = (x.sqrt(), y.sqrt(), z.sqrt());
    let lambda = sx * (sy + sz) + sy * sz;
    [
        0.25 * (x + lambda),
        0.25 * (y + lambda),
        0.25 * (z + lambda),
    ]
}

/// One step of the arithmetic–geometric mean.
#[inline(always)]
pub(super) fn agm_step(a: f64, b: f64) -> (f64, f64) {
    (0.5 * (a + b), (a * b).sqrt())
}

/// The arithmetic–geometric mean of 1 and `b` (0 < b ≤ 1) by
/// [`AGM_STEPS`] steps.
/// (Inline in the set-up, as for [`rf`].)
#[cfg(test)]
pub fn agm(b: f64) -> f64 {
    let (mut a, mut b) = (1.0f64, b);
    for _ in 0..AGM_STEPS {
        (a, b) = agm_step(a, b);
    }
    0.5 * (a + b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::carlson_rf;
    use crate::sampler::rng::mix64;

    fn uniform(state: &mut u64) -> f64 {
        *state += 1;
        (mix64(*state) >> 11) as f64 / (1u64 << 53) as f64
    }

    /// The lanes' `exp`, R_F and AGM against std and the reference.
    #[test]
    fn lane_functions_match_the_reference() {
        let mut st = 7u64;
        for _ in 0..100_000 {
            let x = -750.0 * uniform(&mut st);
            let (got, want) = (exp(x), x.exp());
            assert!(
                (got - want).abs() <= 4e-16 * want || (x < -708.0 && got == 0.0),
                "exp({x}) = {got}, want {want}"
            );
            // R_F(x, y, 1) over the arguments the set-up gives it: x in
            // [0, 1], y from 1e-6 to 1.
            let (a, b) = (uniform(&mut st), 10f64.powf(-6.0 * uniform(&mut st)));
            let (got, want) = (rf(a, b, 1.0), carlson_rf(a, b, 1.0));
            // (Both round some 1e-16 per duplication.)
            assert!((got - want).abs() <= 2e-15 * want, "R_F({a}, {b}, 1)");
            let m = 10f64.powf(-14.0 * uniform(&mut st));
            let (got, want) = (
                std::f64::consts::FRAC_PI_2 / agm(m.sqrt()),
                carlson_rf(0.0, m, 1.0),
            );
            assert!((got - want).abs() <= 1e-15 * want, "K′ at m = {m}");
        }
    }
}
