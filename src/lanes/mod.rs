//! Lane arithmetic: the [`Real`] lane types and their branch-free maths.
//! How lane code is compiled and dispatched is in [`dispatch`].
//!
//! The kernel is written once, per sample, over a [`Real`] (f32 or f64), in
//! loops over structure-of-arrays blocks with no branches, no calls that are
//! not inlined and no allocation, so that LLVM's loop vectoriser turns each
//! loop into full-width SIMD. The block functions are compiled several times
//! with `multiversion` (AVX-512, AVX2+FMA, baseline SSE2) and the widest one
//! the CPU supports is chosen at run time: no `-C target-cpu=native` needed.
//! Fused multiply-adds are written out as [`Real::mul_add`], never left to
//! the compiler: a fused step has one rounding on every target (one
//! instruction where the CPU has FMA, a software fma on the SSE2 baseline,
//! which only CPUs from before 2013 select), so results do not depend on
//! the machine's SIMD width or on its FMA unit.
//!
//! `ln` and `sin_cos_2pi` are our own branch-free polynomial versions (libm's
//! do not vectorise). They are accurate to a few ulp of each type and are
//! tested against `std` below.

// Lane code indexes SoA arrays by lane and contact on purpose: the index
// form is what the loop vectoriser sees through.
#![allow(clippy::needless_range_loop, clippy::manual_memcpy)]
// fdlibm's coefficients are quoted with their published digits.
#![allow(clippy::excessive_precision)]

pub mod dispatch;

use std::ops::{Add, AddAssign, Div, Mul, Neg, Sub};

/// A floating-point lane type: f32 or f64.
pub trait Real:
    Copy
    + Send
    + Sync
    + Default
    + PartialOrd
    + std::fmt::Debug
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + 'static
{
    const ZERO: Self;
    const ONE: Self;
    const HALF: Self;
    /// Machine epsilon.
    const EPSILON: Self;
    const INFINITY: Self;
    const NEG_INFINITY: Self;
    /// Name used in tables: "f32" or "f64".
    const NAME: &'static str;

    fn from_f64(x: f64) -> Self;
    fn to_f64(self) -> f64;
    fn sqrt(self) -> Self;
    fn abs(self) -> Self;
    /// `self · a + b` with one rounding (fused). A single instruction on
    /// the FMA targets; on CPUs without FMA it runs in software with the
    /// same result, so every target rounds identically.
    fn mul_add(self, a: Self, b: Self) -> Self;
    fn min(self, o: Self) -> Self;
    fn max(self, o: Self) -> Self;
    /// A uniform draw in the open interval (0, 1) from 64 random bits:
    /// `(k + ½)·2⁻ᵐ` for the top m bits k (m = 23 for f32, 52 for f64), so
    /// the f32 draw is the f64 draw's top bits.
    fn uniform(bits: u64) -> Self;
    /// A uniform draw in (0, 1) from a 32-bit word `hi` and, in f64 only, 20
    /// more bits `lo` (the low 20 bits of the argument): `(k + ½)·2⁻ᵐ` for
    /// k the top 23 bits of `hi` in f32, and `hi·2²⁰ + lo` in f64. The f32
    /// draw is the f64 draw's top bits, and f32 never reads `lo` (so an f32
    /// caller's `lo` is dead code).
    fn uniform_split(hi: u32, lo: u64) -> Self;
    /// Natural logarithm for finite `x > 0`.
    fn ln(self) -> Self;
    /// `(e, m)` with `self = m·2^e`, m in (√½, √2] (√2 as this type
    /// rounds it), for `ln`: integer operations on the bits only.
    fn ln_reduce(self) -> (Self, Self);
    /// `(sin 2πx, cos 2πx)` for any finite x.
    fn sin_cos_2pi(self) -> (Self, Self);
    /// `sin_cos_2pi` for x in [0, 1] (uniform draws), with a cheaper
    /// quadrant; the same results there.
    fn sin_cos_2pi_unit(self) -> (Self, Self);
    /// `(sin a, cos a)` for a = r·π/2, |r| ≤ ½.
    fn sin_cos_quarter(r: Self) -> (Self, Self);
    /// The nearest integer, halves away from zero (as `f64::round`).
    fn round(self) -> Self;
    /// `atan2(self, x)` in (−π, π] for finite arguments, without branches:
    /// the ratio of the smaller to the larger magnitude, folded above
    /// tan(π/8) by `(r − 1)/(r + 1)`, then fdlibm's arctangent polynomial
    /// on |t| ≤ tan(π/8) and the octant's offsets (with their low parts in
    /// f64). `atan2(0, 0)` is 0 (or π for x = −0, as std).
    fn atan2(self, x: Self) -> Self;
    /// Index of |x| in a log-linear histogram with 2^`sub_bits` bins per
    /// octave from 2^`min_exp`, clamped to `[0, bins)`, from the value's own
    /// bits (so f32 lanes stay 16 wide). Every finite value of the type gets
    /// the bin its f64 conversion would.
    fn log_bin(self, sub_bits: u32, min_exp: i32, bins: i32) -> u16;
}

/// `c₀ + c₁x + c₂x² + …` by Horner's rule with fused steps.
#[inline(always)]
fn horner<T: Real, const K: usize>(c: [T; K], x: T) -> T {
    let mut p = c[K - 1];
    for k in (0..K - 1).rev() {
        p = p.mul_add(x, c[k]);
    }
    p
}

/// `(sin x, cos x)` of an angle in radians, by [`Real::sin_cos_2pi`].
#[inline(always)]
pub fn sin_cos<T: Real>(x: T) -> (T, T) {
    (x * T::from_f64(std::f64::consts::FRAC_1_PI * 0.5)).sin_cos_2pi()
}

/// `if c { a } else { b }` as a value (a blend when vectorised).
#[inline(always)]
pub fn select<T: Real>(c: bool, a: T, b: T) -> T {
    if c {
        a
    } else {
        b
    }
}

macro_rules! real_impl {
    ($t:ty, $bits:ty, $mant:expr, $bias:expr, $name:expr, $uniform:expr, $split:expr,
     ln_coeffs = [$($lc:expr),*], sin_coeffs = [$($sc:expr),*], cos_coeffs = [$($cc:expr),*]) => {
        impl Real for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const HALF: Self = 0.5;
            const EPSILON: Self = <$t>::EPSILON;
            const INFINITY: Self = <$t>::INFINITY;
            const NEG_INFINITY: Self = <$t>::NEG_INFINITY;
            const NAME: &'static str = $name;

            #[inline(always)]
            fn from_f64(x: f64) -> Self {
                x as $t
            }
            #[inline(always)]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline(always)]
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            #[inline(always)]
            fn abs(self) -> Self {
                <$t>::abs(self)
            }
            #[inline(always)]
            fn mul_add(self, a: Self, b: Self) -> Self {
                <$t>::mul_add(self, a, b)
            }
            #[inline(always)]
            fn min(self, o: Self) -> Self {
                if self < o { self } else { o }
            }
            #[inline(always)]
            fn max(self, o: Self) -> Self {
                if self > o { self } else { o }
            }
            #[inline(always)]
            fn uniform(bits: u64) -> Self {
                let f: fn(u64) -> $t = $uniform;
                f(bits)
            }
            #[inline(always)]
            fn uniform_split(hi: u32, lo: u64) -> Self {
                let f: fn(u32, u64) -> $t = $split;
                f(hi, lo)
            }
            #[inline(always)]
            fn ln(self) -> Self {
                // x = m·2^e with m in (√½, √2]; ln m = 2 atanh(s), s = (m−1)/(m+1).
                let (e, m) = self.ln_reduce();
                let s = (m - 1.0) / (m + 1.0);
                let s2 = s * s;
                let p = horner([$($lc as $t),*], s2);
                e.mul_add(core::f64::consts::LN_2 as $t, 2.0 * s * p)
            }
            #[inline(always)]
            fn ln_reduce(self) -> (Self, Self) {
                // Adding 2^mant − f_c to the bits, for f_c the mantissa
                // field of the smallest m above √2, carries into the
                // exponent exactly when the mantissa field is ≥ f_c; adding
                // C back to the low bits (exponent field bias − 1) gives m
                // or m/2. The same (e, m) as comparing m with √2 and
                // halving (tested), in integer operations: i32 arithmetic
                // for the exponent, whose conversion vectorises on every
                // target (i64 ones need AVX-512).
                const MANT_MASK: $bits = ((1 as $bits) << $mant) - 1;
                const C: $bits = ((core::f64::consts::SQRT_2 as $t).to_bits() + 1) - (1 << $mant);
                const SHIFT: $bits = (($bias as $bits) << $mant) - C;
                let b = self.to_bits().wrapping_add(SHIFT);
                let e = (((b >> $mant) as i32) - $bias) as $t;
                (e, <$t>::from_bits((b & MANT_MASK) + C))
            }
            #[inline(always)]
            fn sin_cos_2pi(self) -> (Self, Self) {
                // Quarter turns: t = 4x = q + r, |r| ≤ ½, angle r·π/2 ≤ π/4.
                let t = self * 4.0;
                let q = t.round_ties_even();
                let (s, c) = Self::sin_cos_quarter(t - q);
                // The quadrant q mod 4 in float arithmetic (exact: q is an
                // integer), which vectorises where float → int casts do not.
                let quadrant = q - 4.0 * (q * 0.25).floor();
                let odd = (quadrant == 1.0) | (quadrant == 3.0);
                let (s1, c1) = if odd { (c, -s) } else { (s, c) };
                if quadrant >= 2.0 { (-s1, -c1) } else { (s1, c1) }
            }
            #[inline(always)]
            fn sin_cos_2pi_unit(self) -> (Self, Self) {
                // As `sin_cos_2pi`, for x in [0, 1]: q is 0…4 and is its own
                // quadrant (4 is 0), so no reduction of q is needed. Same
                // results bit for bit.
                let t = self * 4.0;
                let q = t.round_ties_even();
                let (s, c) = Self::sin_cos_quarter(t - q);
                let odd = (q == 1.0) | (q == 3.0);
                let (s1, c1) = if odd { (c, -s) } else { (s, c) };
                if (q == 2.0) | (q == 3.0) { (-s1, -c1) } else { (s1, c1) }
            }
            #[inline(always)]
            fn log_bin(self, sub_bits: u32, min_exp: i32, bins: i32) -> u16 {
                // |x|'s bits shifted so that the biased exponent and the
                // top `sub_bits` of the mantissa are one integer
                // (exponent · 2^sub_bits + sub-bin); then one offset.
                let top = (self.abs().to_bits() >> ($mant - sub_bits)) as i32;
                (top - (($bias + min_exp) << sub_bits)).clamp(0, bins - 1) as u16
            }
            #[inline(always)]
            fn round(self) -> Self {
                <$t>::round(self)
            }
            #[inline(always)]
            fn atan2(self, x: Self) -> Self {
                let y = self;
                let (ax, ay) = (x.abs(), y.abs());
                let swap = ay > ax;
                let (num, den) = if swap { (ax, ay) } else { (ay, ax) };
                // 0/0 is 0 (both zero): the angle then comes from the signs.
                let r = num / if den > 0.0 { den } else { 1.0 };
                let fold = r > 4.14213562373095048802e-01 as $t;
                let t = if fold { (r - 1.0) / (r + 1.0) } else { r };
                let z = t * t;
                let w = z * z;
                // fdlibm's aT, split into the odd and even terms in w.
                let odd = z * horner(
                    [
                        3.33333333333329318027e-01 as $t,
                        1.42857142725034663711e-01 as $t,
                        9.09088713343650656196e-02 as $t,
                        6.66107313738753120669e-02 as $t,
                        4.97687799461593236017e-02 as $t,
                        1.62858201153657823623e-02 as $t,
                    ],
                    w,
                );
                let even = w * horner(
                    [
                        -1.99999999998764832476e-01 as $t,
                        -1.11111104054623557880e-01 as $t,
                        -7.69187620504482999495e-02 as $t,
                        -5.83357013379057348645e-02 as $t,
                        -3.65315727442169155270e-02 as $t,
                    ],
                    w,
                );
                let corr = t * (odd + even);
                // atan(r) on [0, 1]: t − corr, or π/4 + atan(t).
                let a = if fold {
                    core::f64::consts::FRAC_PI_4 as $t
                        - ((corr - 3.06161699786838301793e-17 as $t) - t)
                } else {
                    t - corr
                };
                // The octant: π/2 − a where |y| > |x|, π − a where x < 0.
                let a = if swap {
                    core::f64::consts::FRAC_PI_2 as $t - (a - 6.12323399573676603587e-17 as $t)
                } else {
                    a
                };
                let a = if x.is_sign_negative() {
                    core::f64::consts::PI as $t - (a - 1.22464679914735317720e-16 as $t)
                } else {
                    a
                };
                if y.is_sign_negative() { -a } else { a }
            }
            #[inline(always)]
            fn sin_cos_quarter(r: Self) -> (Self, Self) {
                let a = r * core::f64::consts::FRAC_PI_2 as $t;
                let a2 = a * a;
                (a * horner([$($sc as $t),*], a2), horner([$($cc as $t),*], a2))
            }
        }
    };
}

// f32: atanh series 1 + s²/3 + s⁴/5 + … for ln (|s| ≤ 0.1716), and the
// Cephes single-precision minimax fits of sinf and cosf on |a| ≤ π/4
// (S. L. Moshier; 4 and 5 terms instead of 5 and 6 Taylor terms).
real_impl!(
    f32,
    u32,
    23,
    127,
    "f32",
    // (k + ½)·2⁻²³ for the top 23 bits k, as (1 + k·2⁻²³) − (1 − 2⁻²⁴):
    // both exact (Sterbenz), with no integer → float conversion.
    |bits| f32::from_bits(0x3f80_0000 | (bits >> 41) as u32) - (1.0 - 1.0 / 16_777_216.0),
    |hi, _lo| f32::from_bits(0x3f80_0000 | (hi >> 9)) - (1.0 - 1.0 / 16_777_216.0),
    ln_coeffs = [1.0, 1.0 / 3.0, 1.0 / 5.0, 1.0 / 7.0, 1.0 / 9.0],
    sin_coeffs = [1.0, -1.6666654611e-1, 8.3321608736e-3, -1.9515295891e-4],
    cos_coeffs = [
        1.0,
        -0.5,
        4.166664568298827e-2,
        -1.388731625493765e-3,
        2.443315711809948e-5
    ]
);
// f64: the minimax fits of fdlibm (Sun Microsystems, freely
// distributable; the same numbers as musl and openlibm): __kernel_sin's
// S1–S6 and __kernel_cos's C1–C6 on |a| ≤ π/4, and __ieee754_log's Lg1–Lg7
// (halved: our series is ln m = 2s·p(s²), fdlibm's 2s + s·R(s²)) on the same
// range of s. Fewer terms than the Taylor series for the same accuracy.
real_impl!(
    f64,
    u64,
    52,
    1023,
    "f64",
    // (k + ½)·2⁻⁵² for the top 52 bits k, as (1 + k·2⁻⁵²) − (1 − 2⁻⁵³).
    |bits| f64::from_bits(0x3ff0_0000_0000_0000 | (bits >> 12))
        - (1.0 - 1.0 / 9_007_199_254_740_992.0),
    |hi, lo| f64::from_bits(0x3ff0_0000_0000_0000 | ((hi as u64) << 20) | (lo & 0xf_ffff))
        - (1.0 - 1.0 / 9_007_199_254_740_992.0),
    ln_coeffs = [
        1.0,
        6.666666666666735130e-01 / 2.0,
        3.999999999940941908e-01 / 2.0,
        2.857142874366239149e-01 / 2.0,
        2.222219843214978396e-01 / 2.0,
        1.818357216161805012e-01 / 2.0,
        1.531383769920937332e-01 / 2.0,
        1.479819860511658591e-01 / 2.0
    ],
    sin_coeffs = [
        1.0,
        -1.66666666666666324348e-01,
        8.33333333332248946124e-03,
        -1.98412698298579493134e-04,
        2.75573137070700676789e-06,
        -2.50507602534068634195e-08,
        1.58969099521155010221e-10
    ],
    cos_coeffs = [
        1.0,
        -0.5,
        4.16666666666666019037e-02,
        -1.38888888888741095749e-03,
        2.48015872894767294178e-05,
        -2.75573143513906633035e-07,
        2.08757232129817482790e-09,
        -1.13596475577881948265e-11
    ]
);

/// Sixteen lanes of a [`Real`] as one value, for the statistics' masked sums.
///
/// LLVM's SLP vectoriser does not pack scalar partial sums kept in an
/// array, but it does pack whole-value operations on an aligned lane
/// struct: each operation below compiles to one AVX-512 instruction for f32
/// (two for f64; more on AVX2 and SSE2). Lane j always sums the same samples
/// in the same order, so results do not depend on the SIMD width.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(64))]
pub struct X16<T>(pub [T; 16]);

macro_rules! x16_binop {
    ($trait:ident, $name:ident, $op:tt) => {
        impl<T: Real> $trait for X16<T> {
            type Output = Self;
            #[inline(always)]
            fn $name(self, o: Self) -> Self {
                let mut r = self;
                for j in 0..16 {
                    r.0[j] = self.0[j] $op o.0[j];
                }
                r
            }
        }
    };
}
x16_binop!(Add, add, +);
x16_binop!(Sub, sub, -);
x16_binop!(Mul, mul, *);

impl<T: Real> X16<T> {
    #[inline(always)]
    pub fn splat(x: T) -> Self {
        Self([x; 16])
    }
    /// Lanes `16c .. 16c + 16` of `xs`.
    #[inline(always)]
    pub fn load(xs: &[T], c: usize) -> Self {
        let mut r = Self([T::ZERO; 16]);
        r.0.copy_from_slice(&xs[16 * c..16 * c + 16]);
        r
    }
    /// Lane-wise minimum (operands are never NaN here).
    #[inline(always)]
    pub fn min(self, o: Self) -> Self {
        let mut r = self;
        for j in 0..16 {
            r.0[j] = if o.0[j] < self.0[j] {
                o.0[j]
            } else {
                self.0[j]
            };
        }
        r
    }
    #[inline(always)]
    pub fn max(self, o: Self) -> Self {
        let mut r = self;
        for j in 0..16 {
            r.0[j] = if o.0[j] > self.0[j] {
                o.0[j]
            } else {
                self.0[j]
            };
        }
        r
    }
    /// Every lane in f64.
    #[inline(always)]
    pub fn to_f64(self) -> X16<f64> {
        let mut r = X16([0.0; 16]);
        for j in 0..16 {
            r.0[j] = self.0[j].to_f64();
        }
        r
    }
    /// Sum of the lanes by halving (for exact sums: counts).
    #[inline(always)]
    pub fn tree_sum(self) -> T {
        self.tree(|a, b| a + b)
    }
    #[inline(always)]
    pub fn tree_min(self) -> T {
        self.tree(|a, b| if b < a { b } else { a })
    }
    #[inline(always)]
    pub fn tree_max(self) -> T {
        self.tree(|a, b| if b > a { b } else { a })
    }
    #[inline(always)]
    fn tree(self, f: impl Fn(T, T) -> T) -> T {
        let mut x = self.0;
        let mut half = 8;
        while half > 0 {
            for j in 0..half {
                x[j] = f(x[j], x[j + half]);
            }
            half /= 2;
        }
        x[0]
    }
    /// `a` in lanes where `w > 0`, else `b`.
    #[inline(always)]
    pub fn select_positive(w: Self, a: Self, b: Self) -> Self {
        let mut r = a;
        for j in 0..16 {
            r.0[j] = if w.0[j] > T::ZERO { a.0[j] } else { b.0[j] };
        }
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ln_matches_std() {
        let mut worst32 = 0f64;
        let mut worst64 = 0f64;
        for i in 1..20000 {
            let x = (i as f64 / 20000.0).powi(3) * 3.0 + 1e-30 * i as f64;
            let e64 = (Real::ln(x) - x.ln()).abs() / x.ln().abs().max(1.0);
            let x32 = x as f32;
            let e32 =
                (Real::ln(x32) as f64 - (x32 as f64).ln()).abs() / (x32 as f64).ln().abs().max(1.0);
            worst64 = worst64.max(e64);
            worst32 = worst32.max(e32);
        }
        assert!(worst64 < 4.0 * f64::EPSILON, "f64 ln error {worst64:e}");
        assert!(
            worst32 < 4.0 * f32::EPSILON as f64,
            "f32 ln error {worst32:e}"
        );
        assert!((Real::ln(f64::MIN_POSITIVE) - f64::MIN_POSITIVE.ln()).abs() < 1e-12);
    }

    /// `ln_reduce` is the reduction by comparison with √2 and halving,
    /// bit for bit: around the √2 boundary and across the mantissas of
    /// every exponent (subnormals included), in both types.
    #[test]
    fn ln_reduction_is_the_halving_one() {
        fn halving32(x: f32) -> (f32, f32) {
            let bits = x.to_bits();
            let m = f32::from_bits((bits & 0x7f_ffff) | (127 << 23));
            let big = m > std::f32::consts::SQRT_2;
            let e = ((bits >> 23) as i32 - 127 + big as i32) as f32;
            (e, if big { m * 0.5 } else { m })
        }
        fn halving64(x: f64) -> (f64, f64) {
            let bits = x.to_bits();
            let m = f64::from_bits((bits & 0xf_ffff_ffff_ffff) | (1023 << 52));
            let big = m > std::f64::consts::SQRT_2;
            let e = ((bits >> 52) as i64 - 1023 + big as i64) as f64;
            (e, if big { m * 0.5 } else { m })
        }
        let boundary32 = std::f32::consts::SQRT_2.to_bits() & 0x7f_ffff;
        let boundary64 = std::f64::consts::SQRT_2.to_bits() & 0xf_ffff_ffff_ffff;
        for exp in 0..255u32 {
            let near = (0..4000u32).map(|k| boundary32 - 2000 + k);
            for f in near.chain((0..0x80_0000).step_by(997)) {
                let x = f32::from_bits(exp << 23 | f);
                if x > 0.0 {
                    let (got, want) = (x.ln_reduce(), halving32(x));
                    assert_eq!(got.0.to_bits(), want.0.to_bits(), "{x:e}");
                    assert_eq!(got.1.to_bits(), want.1.to_bits(), "{x:e}");
                }
            }
        }
        for exp in 0..2047u64 {
            let near = (0..400u64).map(|k| boundary64 - 200 + k);
            let spread = (0..400u64).map(|k| k * 0x2_8f5c_28f5_c28f % 0x10_0000_0000_0000);
            for f in near.chain(spread) {
                let x = f64::from_bits(exp << 52 | f);
                if x > 0.0 {
                    let (got, want) = (x.ln_reduce(), halving64(x));
                    assert_eq!(got.0.to_bits(), want.0.to_bits(), "{x:e}");
                    assert_eq!(got.1.to_bits(), want.1.to_bits(), "{x:e}");
                }
            }
        }
    }

    #[test]
    fn sin_cos_match_std() {
        let mut worst64 = 0f64;
        let mut worst32 = 0f64;
        for i in 0..=40000 {
            let x = i as f64 / 40000.0 * 2.0 - 0.5;
            let (s, c) = Real::sin_cos_2pi(x);
            let (ss, cc) = (std::f64::consts::TAU * x).sin_cos();
            // std's argument 2πx itself carries a rounding of 2π|x|·ε.
            let allowance = 1.0 + std::f64::consts::TAU * x.abs();
            worst64 = worst64
                .max((s - ss).abs() / allowance)
                .max((c - cc).abs() / allowance);
            let (s32, c32) = Real::sin_cos_2pi(x as f32);
            let (ss, cc) = (std::f64::consts::TAU * (x as f32) as f64).sin_cos();
            worst32 = worst32
                .max((s32 as f64 - ss).abs())
                .max((c32 as f64 - cc).abs());
        }
        assert!(
            worst64 < 4.0 * f64::EPSILON,
            "f64 sin/cos error {worst64:e}"
        );
        assert!(
            worst32 < 4.0 * f32::EPSILON as f64,
            "f32 sin/cos error {worst32:e}"
        );
    }

    /// Against std over every octant, near the fold and the axes: within
    /// 2 ulp of the angle's magnitude in f64 and 2 f32 ulp in f32.
    #[test]
    fn atan2_matches_std() {
        let mut worst = (0f64, 0f64);
        let mut rng = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut cases: Vec<(f64, f64)> = (0..200_000)
            .map(|_| {
                let a = (next() * 2.0 - 1.0) * std::f64::consts::PI;
                let r = 10f64.powf(next() * 12.0 - 6.0);
                (r * a.sin(), r * a.cos())
            })
            .collect();
        let t8 = (std::f64::consts::PI / 8.0).tan();
        for (y, x) in [(t8, 1.0), (1.0, 1.0), (1.0, 0.0), (0.0, -1.0), (-0.0, -1.0)] {
            cases.extend([(y, x), (-y, x), (y, -x), (-y, -x), (x, y)]);
        }
        cases.extend([
            (0.0, 0.0),
            (-0.0, 0.0),
            (0.0, -0.0),
            (1e-300, 1.0),
            (1.0, 1e-300),
        ]);
        for (y, x) in cases {
            let want = y.atan2(x);
            let got = Real::atan2(y, x);
            let ulp = f64::EPSILON * want.abs().max(f64::MIN_POSITIVE);
            worst.0 = worst.0.max((got - want).abs() / ulp);
            let (y32, x32) = (y as f32, x as f32);
            let want32 = (y32 as f64).atan2(x32 as f64);
            let got32 = Real::atan2(y32, x32) as f64;
            let ulp32 = f32::EPSILON as f64 * want32.abs().max(f32::MIN_POSITIVE as f64);
            worst.1 = worst.1.max((got32 - want32).abs() / ulp32);
            assert_eq!(got.is_sign_negative(), want.is_sign_negative(), "{y} {x}");
        }
        assert!(worst.0 <= 2.0, "f64 atan2 error {} ulp", worst.0);
        assert!(worst.1 <= 2.0, "f32 atan2 error {} ulp", worst.1);
    }

    #[test]
    fn unit_sin_cos_is_the_general_one_on_the_unit_interval() {
        for i in 0..=100_000 {
            let x = i as f64 / 100_000.0;
            assert_eq!(Real::sin_cos_2pi_unit(x), Real::sin_cos_2pi(x), "{x}");
            let x = x as f32;
            assert_eq!(Real::sin_cos_2pi_unit(x), Real::sin_cos_2pi(x), "{x}");
        }
    }

    #[test]
    fn uniforms_are_open_interval() {
        assert!(<f32 as Real>::uniform(0) > 0.0 && <f32 as Real>::uniform(u64::MAX) < 1.0);
        assert!(<f64 as Real>::uniform(0) > 0.0 && <f64 as Real>::uniform(u64::MAX) < 1.0);
    }
}
