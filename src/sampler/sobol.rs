//! Owen-scrambled Sobol points for randomized quasi-Monte Carlo (RQMC).
//!
//! The points are Sobol's sequence in base 2 with the Joe–Kuo direction
//! numbers (`new-joe-kuo-6.21201`, S. Joe and F. Y. Kuo, "Constructing
//! Sobol sequences with better two-dimensional projections", SIAM J. Sci.
//! Comput. 30, 2008), in Gray-code order as Joe and Kuo's own generator and
//! scipy's `qmc.Sobol` give them, with 32 digits: 2³² points per replicate.
//!
//! Each replicate is an independent nested uniform (Owen) scramble of the
//! same points, hash-based as in B. Burley, "Practical Hash-based Owen
//! Scrambling", JCGT 9(4), 2020: in bit-reversed order, a function in
//! which each output bit is its input bit XOR a function of the lower
//! (there: more significant) bits and the seed, with N. Vegdahl's
//! constants ("Building a Better LK Hash", 2021); then a random digital
//! shift, which makes every point exactly uniform on the 2⁻³² grid. Both
//! keep the net property: the first 2^m points of a replicate are a
//! (t, m, s)-net whenever the unscrambled ones are.
//!
//! Everything is a pure function of (seed, replicate, point, dimension):
//! no state, so every thread, batch, lane and shard draws the same.

use std::sync::LazyLock;

use crate::sampler::rng::mix64;

/// Dimensions with direction numbers (the first lines of Joe and Kuo's
/// table; a sample uses nine, a drop twelve).
pub const DIMENSIONS: usize = 32;

/// Digits of a point: 2³² points per replicate, as scenes are told.
pub const DIGITS: u32 = 32;
const _: () = assert!(DIGITS == crate::config::MAX_LOG2_POINTS);

/// The first lines of Joe and Kuo's `new-joe-kuo-6.21201`, in its own
/// format (`d s a m_1 … m_s`; dimension 1 is van der Corput's and has no
/// line).
const JOE_KUO: &str = include_str!("new-joe-kuo-6.21201.head");

/// Low bits of a table index: a point within an aligned run of
/// [`TABLE`] points is one lookup and one XOR away from the run's first.
const TABLE_BITS: u32 = 8;
pub(crate) const TABLE: usize = 1 << TABLE_BITS;

/// Direction numbers, bit-reversed (the scramble works on reversed
/// digits), and the reversed points `0 .. TABLE` of each dimension.
struct Tables {
    /// `reversed[d][k]`: direction number k of dimension d, reversed.
    reversed: [[u32; DIGITS as usize]; DIMENSIONS],
    /// `first[d][s]`: the reversed unscrambled point s of dimension d.
    first: [[u32; TABLE]; DIMENSIONS],
}

static TABLES: LazyLock<Box<Tables>> = LazyLock::new(|| {
    let v = direction_numbers();
    let mut t = Box::new(Tables {
        reversed: [[0; DIGITS as usize]; DIMENSIONS],
        first: [[0; TABLE]; DIMENSIONS],
    });
    for d in 0..DIMENSIONS {
        for k in 0..DIGITS as usize {
            t.reversed[d][k] = v[d][k].reverse_bits();
        }
        for s in 0..TABLE {
            t.first[d][s] = xor_of(&t.reversed[d], gray(s as u64));
        }
    }
    t
});

/// The direction numbers `v[d][k]` (32 bits, most significant first) of
/// the first [`DIMENSIONS`] dimensions, from Joe and Kuo's table:
/// `v_k = m_k·2^(32−k)`, and past the initial `m` the recurrence of their
/// primitive polynomial (Bratley & Fox, ACM TOMS 14, 1988).
pub fn direction_numbers() -> Vec<[u32; DIGITS as usize]> {
    let mut out = Vec::with_capacity(DIMENSIONS);
    // Dimension 1: all m_k = 1.
    out.push(std::array::from_fn(|k| 1u32 << (31 - k)));
    for line in JOE_KUO.lines().skip(1).take(DIMENSIONS - 1) {
        let f: Vec<u32> = line
            .split_whitespace()
            .map(|x| x.parse().expect("Joe–Kuo table: integers"))
            .collect();
        let (s, a, m) = (f[1] as usize, f[2], &f[3..]);
        assert_eq!(m.len(), s, "Joe–Kuo table: dimension {}", f[0]);
        let mut v = [0u32; DIGITS as usize];
        for k in 0..DIGITS as usize {
            v[k] = if k < s {
                m[k] << (31 - k)
            } else {
                let mut x = v[k - s] ^ (v[k - s] >> s);
                for j in 1..s {
                    if (a >> (s - 1 - j)) & 1 == 1 {
                        x ^= v[k - j];
                    }
                }
                x
            };
        }
        out.push(v);
    }
    assert_eq!(out.len(), DIMENSIONS, "Joe–Kuo table: too few lines");
    out
}

/// The Gray code of `i`: point i of the sequence is the XOR of the
/// direction numbers of its set bits.
#[inline(always)]
fn gray(i: u64) -> u64 {
    i ^ (i >> 1)
}

/// XOR of `v[k]` over the set bits k < 32 of `g`.
#[inline(always)]
fn xor_of(v: &[u32; DIGITS as usize], g: u64) -> u32 {
    let mut g = g & 0xffff_ffff;
    let mut x = 0;
    while g != 0 {
        x ^= v[g.trailing_zeros() as usize];
        g &= g - 1;
    }
    x
}

/// Point `i` of dimension `d`, unscrambled, as a 32-bit fraction (most
/// significant digit first).
pub fn unscrambled(i: u64, d: usize) -> u32 {
    assert!(i < 1 << DIGITS && d < DIMENSIONS);
    xor_of(&TABLES.reversed[d], gray(i)).reverse_bits()
}

/// The nested scramble in bit-reversed order: each bit of the result is
/// the same bit of `x` XOR a function of the lower bits and the seed
/// (multiplications by even constants and additions carry upward only).
#[inline(always)]
fn lk_hash(mut x: u32, seed: u32) -> u32 {
    x ^= x.wrapping_mul(0x3d20_adea);
    x = x.wrapping_add(seed);
    x = x.wrapping_mul((seed >> 16) | 1);
    x ^= x.wrapping_mul(0x0552_6c56);
    x ^= x.wrapping_mul(0x53a2_2864);
    x
}

/// One dimension's scramble in one replicate: the hash seed and the
/// digital shift.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Scramble {
    seed: u32,
    shift: u32,
}

impl Scramble {
    /// A reversed unscrambled point, scrambled, in natural digit order.
    #[inline(always)]
    pub fn apply(self, reversed: u32) -> u32 {
        lk_hash(reversed, self.seed).reverse_bits() ^ self.shift
    }
}

/// The scrambled Sobol points of a run: replicates of `2^log2_points`
/// points each, sample i in replicate `i >> log2_points`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Sobol {
    key: u64,
    log2_points: u32,
}

impl Sobol {
    /// The points keyed by `seed` (a run's seed, mixed with a stream key),
    /// `2^log2_points` per replicate.
    pub fn new(seed: u64, log2_points: u32) -> Self {
        assert!(log2_points <= DIGITS, "at most 2^32 points per replicate");
        // Build the tables now, not inside the first block.
        LazyLock::force(&TABLES);
        Self {
            key: mix64(seed ^ 0x5c0b_01d5_c4a3_b1e5),
            log2_points,
        }
    }

    /// Points per replicate, as a power of two.
    pub fn log2_points(&self) -> u32 {
        self.log2_points
    }

    /// The replicate of sample `i`.
    #[inline(always)]
    pub fn replicate(&self, i: u64) -> u64 {
        i >> self.log2_points
    }

    /// Dimension `d`'s scramble in replicate `r`.
    #[inline(always)]
    pub fn scramble(&self, r: u64, d: usize) -> Scramble {
        let h = mix64(
            self.key
                .wrapping_add(r.wrapping_mul(DIMENSIONS as u64).wrapping_add(d as u64))
                .wrapping_mul(0x9e37_79b9_7f4a_7c15),
        );
        Scramble {
            seed: h as u32,
            shift: (h >> 32) as u32,
        }
    }

    /// Sample `i`'s coordinate `d`: 32 scrambled digits, most significant
    /// first (the top bits of a uniform draw).
    #[inline(always)]
    pub fn point(&self, i: u64, d: usize) -> u32 {
        let k = i & ((1u64 << self.log2_points) - 1);
        self.scramble(self.replicate(i), d)
            .apply(xor_of(&TABLES.reversed[d], gray(k)))
    }

    /// Coordinates `d` of samples `first .. first + N` into `out`, which
    /// must all lie in one replicate: per aligned run of [`TABLE`] points
    /// one XOR of direction numbers, then per sample one table lookup, one
    /// XOR and the scramble. The same values as [`Self::point`].
    #[inline(always)]
    pub fn points<const N: usize>(&self, first: u64, d: usize, out: &mut [u32; N]) {
        self.points_map(first, d, out, |x| x);
    }

    /// [`Self::points`], each point mapped by `f` on the way out.
    #[inline(always)]
    pub fn points_map<U, const N: usize>(
        &self,
        first: u64,
        d: usize,
        out: &mut [U; N],
        f: impl Fn(u32) -> U,
    ) {
        debug_assert_eq!(
            self.replicate(first),
            self.replicate(first + N as u64 - 1),
            "a block within one replicate"
        );
        let t = &**TABLES;
        let sc = self.scramble(self.replicate(first), d);
        let mask = (1u64 << self.log2_points) - 1;
        let k0 = first & mask;
        // The runs of TABLE points a block of N ≤ TABLE samples meets:
        // at most two.
        let run0 = k0 >> TABLE_BITS;
        let base = [
            xor_of(&t.reversed[d], gray(run0 << TABLE_BITS)),
            xor_of(&t.reversed[d], gray((run0 + 1) << TABLE_BITS)),
        ];
        let table = &t.first[d];
        let low = (k0 & (TABLE as u64 - 1)) as usize;
        // Two contiguous segments (the loops vectorise): the samples in the
        // first run, then those in the next.
        let split = N.min(TABLE - low);
        let (head, tail) = out.split_at_mut(split);
        for (o, &x) in head.iter_mut().zip(&table[low..low + split]) {
            *o = f(sc.apply(base[0] ^ x));
        }
        for (o, &x) in tail.iter_mut().zip(&table[..N - split]) {
            *o = f(sc.apply(base[1] ^ x));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The block form gives the point form, across runs of the table and
    /// replicate boundaries.
    #[test]
    fn blocks_are_the_points() {
        for log2 in [8u32, 9, 12, 20] {
            let s = Sobol::new(17, log2);
            for first in [0u64, 64, 192, 250, 1000, 5 << log2, (7 << log2) - 192] {
                let mut out = [0u32; 192];
                if s.replicate(first) != s.replicate(first + 191) {
                    continue;
                }
                for d in [0, 3, 11] {
                    s.points(first, d, &mut out);
                    for (l, &x) in out.iter().enumerate() {
                        assert_eq!(x, s.point(first + l as u64, d), "2^{log2} {first}+{l} d{d}");
                    }
                }
            }
        }
    }

    /// The bit-reversed hash is a nested scramble: flipping input bit k
    /// (reversed order) never changes output bits below k, and always
    /// changes bit k.
    #[test]
    fn the_hash_is_nested() {
        let mut z = 1u64;
        for _ in 0..2000 {
            z = mix64(z);
            let (x, seed) = (z as u32, (z >> 32) as u32);
            for k in 0..32 {
                let d = lk_hash(x, seed) ^ lk_hash(x ^ (1 << k), seed);
                assert_eq!(d & ((1u32 << k) - 1), 0, "bit {k} reached lower bits");
                assert_eq!((d >> k) & 1, 1, "bit {k} did not flip");
            }
        }
    }
}
