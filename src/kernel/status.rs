//! A lane's status word: what a block pass found about one sample's
//! impact, as named bits over a `u32`. The layout is that of the
//! `flags_LAW` column (bits 0–14) and the golden files' README; it is
//! written here once, and [`Flags`] converts to and from it.

use std::fmt;
use std::ops::{BitAnd, BitOr, BitOrAssign};

use crate::physics::Flags;

/// A lane's status: named bits (see the module docs). Per contact i the
/// approaching, active and sticking bits are [`Status::approaching`],
/// [`Status::active`] and [`Status::sticking`]; contacts 0–3 sit at bits
/// 0–3, 4–7 and 16–19, contacts 4–5 (a drop has up to six planes) at bits
/// 22–23, 24–25 and 26–27, so that the first four keep their documented
/// positions.
#[derive(Clone, Copy, Default, PartialEq, Eq, Hash)]
#[repr(transparent)]
pub struct Status(u32);

/// Where a per-contact kind starts: contacts 0–3 at `low`, 4–5 at `high`.
const APPROACHING: (u32, u32) = (0, 22);
const ACTIVE: (u32, u32) = (4, 24);
const STICKING: (u32, u32) = (16, 26);

impl Status {
    /// Nothing found.
    pub const NONE: Status = Status(0);
    /// The fast path cannot vouch for the lane: the f64 reference solves it
    /// again (and then sets [`Status::RECOMPUTED`]).
    pub const NEEDS_REFERENCE: Status = Status(1 << 8);
    /// `T⁺ > T⁻(1 + 1e-9)`.
    pub const ENERGY_GAIN: Status = Status(1 << 9);
    /// G over the touching contacts is singular or nearly so.
    pub const DEGENERATE: Status = Status(1 << 10);
    /// The Newton LCP had no solution; the plastic one was used.
    pub const JAMMED: Status = Status(1 << 11);
    /// No acceptable solution was found (see [`Flags::unsolved`]).
    pub const UNSOLVED: Status = Status(1 << 12);
    /// A plane outside the placement touches or is penetrated: the sample
    /// is left out of the statistics.
    pub const PENETRATING: Status = Status(1 << 13);
    /// The lane was solved by the f64 reference.
    pub const RECOMPUTED: Status = Status(1 << 14);
    /// With friction: several valid single-contact solutions.
    pub const AMBIGUOUS: Status = Status(1 << 20);
    /// With friction: neither Gauss–Seidel converged.
    pub const UNCONVERGED: Status = Status(1 << 21);

    /// The status word as stored and written.
    #[inline(always)]
    pub const fn bits(self) -> u32 {
        self.0
    }

    /// A status from its stored word.
    #[inline(always)]
    pub const fn from_bits(bits: u32) -> Self {
        Status(bits)
    }

    /// Whether any bit of `other` is set.
    #[inline(always)]
    pub const fn has(self, other: Status) -> bool {
        self.0 & other.0 != 0
    }

    /// `s` when `c` holds, else nothing, without a branch.
    #[inline(always)]
    pub const fn when(c: bool, s: Status) -> Status {
        Status((c as u32) * s.0)
    }

    /// Contact `i`'s approaching bit (touching and `v_n < 0` before).
    #[inline(always)]
    pub const fn approaching(i: usize) -> Status {
        Status(contact_bit(i, APPROACHING))
    }

    /// Contact `i`'s active bit (λ_i > 0).
    #[inline(always)]
    pub const fn active(i: usize) -> Status {
        Status(contact_bit(i, ACTIVE))
    }

    /// Contact `i`'s sticking bit (with friction: active, and ended with
    /// `|c⁺_t| ≤ 1e-9 ×` the velocity scale).
    #[inline(always)]
    pub const fn sticking(i: usize) -> Status {
        Status(contact_bit(i, STICKING))
    }

    /// The approaching contacts, as a mask over `N` contacts (bit i:
    /// contact i).
    #[inline(always)]
    pub fn approaching_mask<const N: usize>(self) -> u32 {
        contact_mask::<N>(self.0, APPROACHING)
    }

    /// The active contacts, as a mask over `N` contacts.
    #[inline(always)]
    pub fn active_mask<const N: usize>(self) -> u32 {
        contact_mask::<N>(self.0, ACTIVE)
    }

    /// The contacts that ended sticking, as a mask over `N` contacts.
    #[inline(always)]
    pub fn sticking_mask<const N: usize>(self) -> u32 {
        contact_mask::<N>(self.0, STICKING)
    }
}

/// Contact `i`'s bit of a kind that starts at `(low, high)`.
#[inline(always)]
const fn contact_bit(i: usize, (low, high): (u32, u32)) -> u32 {
    if i < 4 {
        1 << (low + i as u32)
    } else {
        1 << (high + i as u32 - 4)
    }
}

/// The bits of one kind as a mask over `N` contacts.
#[inline(always)]
fn contact_mask<const N: usize>(st: u32, (low, high): (u32, u32)) -> u32 {
    let low_bits = (st >> low) & ((1 << N.min(4)) - 1);
    if N <= 4 {
        low_bits
    } else {
        low_bits | (((st >> high) & ((1 << (N - 4)) - 1)) << 4)
    }
}

/// A field of [`Flags`].
type FlagField = fn(&mut Flags) -> &mut bool;

/// An impact's flags and their bits, in one table.
const FLAG_BITS: [(FlagField, Status); 6] = [
    (|f| &mut f.energy_gain, Status::ENERGY_GAIN),
    (|f| &mut f.degenerate, Status::DEGENERATE),
    (|f| &mut f.jammed, Status::JAMMED),
    (|f| &mut f.unsolved, Status::UNSOLVED),
    (|f| &mut f.ambiguous, Status::AMBIGUOUS),
    (|f| &mut f.unconverged, Status::UNCONVERGED),
];

impl Flags {
    /// The flags' bits of a status word.
    pub fn to_bits(self) -> Status {
        let mut f = self;
        FLAG_BITS.iter().fold(Status::NONE, |s, (on, bit)| {
            s | Status::when(*on(&mut f), *bit)
        })
    }

    /// The flags a status word carries (its other bits ignored).
    pub fn from_bits(status: Status) -> Flags {
        let mut f = Flags::default();
        for (on, bit) in FLAG_BITS {
            *on(&mut f) = status.has(bit);
        }
        f
    }
}

impl BitOr for Status {
    type Output = Status;
    #[inline(always)]
    fn bitor(self, rhs: Status) -> Status {
        Status(self.0 | rhs.0)
    }
}

impl BitOrAssign for Status {
    #[inline(always)]
    fn bitor_assign(&mut self, rhs: Status) {
        self.0 |= rhs.0;
    }
}

impl BitAnd for Status {
    type Output = Status;
    #[inline(always)]
    fn bitand(self, rhs: Status) -> Status {
        Status(self.0 & rhs.0)
    }
}

impl fmt::Debug for Status {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        const NAMED: [(&str, Status); 9] = [
            ("NEEDS_REFERENCE", Status::NEEDS_REFERENCE),
            ("ENERGY_GAIN", Status::ENERGY_GAIN),
            ("DEGENERATE", Status::DEGENERATE),
            ("JAMMED", Status::JAMMED),
            ("UNSOLVED", Status::UNSOLVED),
            ("PENETRATING", Status::PENETRATING),
            ("RECOMPUTED", Status::RECOMPUTED),
            ("AMBIGUOUS", Status::AMBIGUOUS),
            ("UNCONVERGED", Status::UNCONVERGED),
        ];
        let mut parts: Vec<String> = NAMED
            .iter()
            .filter(|(_, b)| self.has(*b))
            .map(|(n, _)| n.to_string())
            .collect();
        for (kind, mask) in [
            ("approaching", self.approaching_mask::<6>()),
            ("active", self.active_mask::<6>()),
            ("sticking", self.sticking_mask::<6>()),
        ] {
            if mask != 0 {
                parts.push(format!("{kind}={mask:#b}"));
            }
        }
        write!(f, "Status({:#x}: {})", self.0, parts.join(" | "))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The documented layout (tests/data/golden/README.md and the
    /// reference's `flags_LAW`), stated here, not read from the code.
    #[test]
    fn bits_sit_where_the_reference_says() {
        assert_eq!(Status::approaching(0).bits(), 1);
        assert_eq!(Status::approaching(3).bits(), 1 << 3);
        assert_eq!(Status::active(0).bits(), 1 << 4);
        assert_eq!(Status::active(2).bits(), 1 << 6);
        assert_eq!(Status::NEEDS_REFERENCE.bits(), 0x100);
        assert_eq!(Status::ENERGY_GAIN.bits(), 0x200);
        assert_eq!(Status::DEGENERATE.bits(), 0x400);
        assert_eq!(Status::JAMMED.bits(), 0x800);
        assert_eq!(Status::UNSOLVED.bits(), 0x1000);
        assert_eq!(Status::PENETRATING.bits(), 0x2000);
        assert_eq!(Status::RECOMPUTED.bits(), 0x4000);
        assert_eq!(Status::sticking(0).bits(), 1 << 16);
        assert_eq!(Status::AMBIGUOUS.bits(), 1 << 20);
        assert_eq!(Status::UNCONVERGED.bits(), 1 << 21);
        assert_eq!(Status::approaching(4).bits(), 1 << 22);
        assert_eq!(Status::active(5).bits(), 1 << 25);
        assert_eq!(Status::sticking(5).bits(), 1 << 27);
    }

    #[test]
    fn masks_gather_contacts_four_and_five() {
        let s = Status::active(1) | Status::active(4) | Status::approaching(5);
        assert_eq!(s.active_mask::<6>(), 0b01_0010);
        assert_eq!(s.approaching_mask::<6>(), 0b10_0000);
        assert_eq!(s.active_mask::<3>(), 0b010);
        assert_eq!(s.sticking_mask::<6>(), 0);
    }

    #[test]
    fn flags_round_trip_through_their_bits() {
        for m in 0u32..64 {
            let f = Flags {
                energy_gain: m & 1 != 0,
                degenerate: m & 2 != 0,
                jammed: m & 4 != 0,
                unsolved: m & 8 != 0,
                ambiguous: m & 16 != 0,
                unconverged: m & 32 != 0,
            };
            let s = f.to_bits();
            assert_eq!(Flags::from_bits(s), f);
            assert_eq!(s.bits().count_ones(), m.count_ones());
            // Other bits do not leak into the flags.
            assert_eq!(
                Flags::from_bits(s | Status::RECOMPUTED | Status::active(2)),
                f
            );
        }
    }
}
