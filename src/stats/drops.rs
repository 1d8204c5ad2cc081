//! Mergeable statistics of a drop study, per law: per bounce (samples
//! reaching it, planes hit, energy ratio, interval, speed before,
//! simultaneity), the sequences of planes hit over the first impacts, the
//! number of impacts, how each sample ended and the final axis up.
//!
//! Every field is a count or [`Moments`], walked by
//! [`crate::stats::accumulators::RunAcc::visit`] like the contact
//! statistics, so shards, merges and clearing treat both alike.

use crate::stats::{Moments, Slot};

/// Tolerances at which the share of simultaneous impacts is reported (m):
/// an impact counts as simultaneous within `tol` if its second-closest plane
/// was within `tol` at the moment of impact.
pub const SIMULTANEITY_TOLERANCES: [f64; 12] = [
    1e-12, 1e-11, 1e-10, 1e-9, 1e-8, 1e-7, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1,
];

/// Whether a run whose searches locate contacts to within `resolved_from`
/// (m, the scene's `toi_tolerance`) resolves simultaneity at `tolerance`:
/// the nearest plane is then within `resolved_from` of zero, so a second
/// plane within a smaller tolerance says nothing the run can tell apart.
pub fn resolved(tolerance: f64, resolved_from: f64) -> bool {
    tolerance >= resolved_from
}

/// Most impacts a sequence of planes hit covers.
pub const SEQUENCE_IMPACTS: usize = 3;

/// Most distinct sequences counted per law (so many planes shorten them).
const SEQUENCE_CELLS: usize = 4096;

/// How a sample's bounces ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ending {
    /// No further impact within the horizon.
    FlewAway,
    /// Kinetic energy after an impact below `energy_floor` of the first
    /// impact's.
    CameToRest,
    /// `effects.bounces` impacts done.
    BounceLimit,
    /// An impact the reference could not solve.
    Unsolved,
    /// Repeated touches without approach (a resting or rolling contact that
    /// free flight cannot follow).
    Stalled,
    /// The bounces on one plane accumulated (a Zeno sequence: approach
    /// speeds falling geometrically below a small share of the walk's
    /// speed scale), and the walk ends at their accumulation time, in
    /// contact with that plane. It may still slide and spin: its energy
    /// left says how much.
    Settled,
}

impl Ending {
    pub const ALL: [Ending; 6] = [
        Ending::FlewAway,
        Ending::CameToRest,
        Ending::BounceLimit,
        Ending::Unsolved,
        Ending::Stalled,
        Ending::Settled,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Ending::FlewAway => "flew_away",
            Ending::CameToRest => "came_to_rest",
            Ending::BounceLimit => "bounce_limit",
            Ending::Unsolved => "unsolved",
            Ending::Stalled => "stalled",
            Ending::Settled => "settled",
        }
    }
}

/// How the walks that ended one way ended: the body axis closest to
/// vertical, the kinetic energy left and the time since release.
#[derive(Debug, Clone, Default)]
pub struct EndingAcc {
    /// Walks by the body axis (a, b, c) closest to vertical at the end.
    pub axis_up: [u64; 3],
    /// Kinetic energy after the walk's last impact (J; the release's if it
    /// had none).
    pub energy_left: Moments,
    /// Time since release at the end (s): the accumulation time of a
    /// settled walk, else the last impact's (0 if none).
    pub time: Moments,
}

/// Statistics of the k-th impact of every sample that reached it.
#[derive(Debug, Clone, Default)]
pub struct BounceAcc {
    pub reached: u64,
    /// By set of planes that took an impulse (bit i: plane i).
    pub sets: Vec<u64>,
    pub energy_ratio: Moments,
    /// Time since release (first impact) or since the previous impact (s).
    pub interval: Moments,
    /// Speed of the centre just before the impact (m/s).
    pub speed_before: Moments,
    /// Impacts whose second-closest plane was within each tolerance of
    /// [`SIMULTANEITY_TOLERANCES`].
    pub within: [u64; 12],
    pub energy_gain: u64,
    pub degenerate: u64,
}

/// One law's drop statistics.
#[derive(Debug, Clone)]
pub struct DropAcc {
    pub samples: u64,
    pub bounces: Vec<BounceAcc>,
    /// Samples by number of impacts (index 0..=bounces).
    pub impacts: Vec<u64>,
    /// Samples by [`Ending`], in [`Ending::ALL`] order.
    pub endings: [u64; 6],
    /// By [`Ending`], in [`Ending::ALL`] order: the axis up, energy left
    /// and time at the end.
    pub by_ending: [EndingAcc; 6],
    /// Settled walks by the plane they settled on.
    pub settled_on: Vec<u64>,
    /// Samples by the sets of planes hit at their first
    /// [`DropAcc::sequence_impacts`] impacts ([`DropAcc::sequence_cell`]).
    pub sequences: Vec<u64>,
    /// Flights and impacts the lanes left to the f64 reference (flights
    /// not closed-form in lanes or over the step budget; impacts the
    /// kernel flagged, on more than three planes or penetrating one).
    pub reference_flights: u64,
    pub reference_impacts: u64,
    /// Flights searched in lanes, and the poses their searches evaluated
    /// (per flight, one per step and one where it stopped).
    pub lane_flights: u64,
    pub lane_poses: u64,
    planes: usize,
}

impl DropAcc {
    pub fn new(planes: usize, bounces: usize) -> Self {
        let mut acc = Self {
            samples: 0,
            bounces: (0..bounces)
                .map(|_| BounceAcc {
                    sets: vec![0; 1 << planes],
                    ..Default::default()
                })
                .collect(),
            impacts: vec![0; bounces + 1],
            endings: [0; 6],
            by_ending: Default::default(),
            settled_on: vec![0; planes],
            sequences: Vec::new(),
            reference_flights: 0,
            reference_impacts: 0,
            lane_flights: 0,
            lane_poses: 0,
            planes,
        };
        acc.sequences = vec![0; (1usize << planes).pow(acc.sequence_impacts() as u32)];
        acc
    }

    /// Walks by the body axis (a, b, c) closest to vertical at the end,
    /// however they ended (of a walk that did not settle or come to rest,
    /// not a resting attitude).
    pub fn final_axis_up(&self) -> [u64; 3] {
        std::array::from_fn(|k| self.by_ending.iter().map(|e| e.axis_up[k]).sum())
    }

    /// Impacts a sequence covers: up to [`SEQUENCE_IMPACTS`], fewer when
    /// the bounce limit is lower or the planes so many that the sequences
    /// would not fit in 4,096 cells.
    pub fn sequence_impacts(&self) -> usize {
        let mut k = SEQUENCE_IMPACTS.min(self.bounces.len());
        while k > 1 && (1usize << self.planes).pow(k as u32) > SEQUENCE_CELLS {
            k -= 1;
        }
        k
    }

    /// The cell of a sample whose first impacts hit the sets `masks` (0 past
    /// its last impact): the masks as digits in base 2^planes, first impact
    /// lowest.
    pub fn sequence_cell(&self, masks: &[usize]) -> usize {
        let base = 1usize << self.planes;
        masks
            .iter()
            .take(self.sequence_impacts())
            .rev()
            .fold(0, |cell, &m| cell * base + m)
    }

    /// The sequence cells that some sample reached, with their counts, most
    /// frequent first (ties by cell).
    pub fn sequences_by_frequency(&self) -> Vec<(usize, u64)> {
        let mut cells: Vec<(usize, u64)> = self
            .sequences
            .iter()
            .copied()
            .enumerate()
            .filter(|&(_, c)| c > 0)
            .collect();
        cells.sort_by(|x, y| y.1.cmp(&x.1).then(x.0.cmp(&y.0)));
        cells
    }

    /// The sets of planes of a cell, first impact first, without the empty
    /// sets past the sample's last impact.
    pub fn sequence_masks(&self, mut cell: usize) -> Vec<usize> {
        let base = 1usize << self.planes;
        let mut masks = Vec::new();
        for _ in 0..self.sequence_impacts() {
            masks.push(cell % base);
            cell /= base;
        }
        while masks.last() == Some(&0) {
            masks.pop();
        }
        masks
    }

    /// Every field in a fixed order, with its path below `prefix`.
    pub(crate) fn walk<'a>(
        &'a mut self,
        prefix: &dyn Fn() -> String,
        f: &mut dyn FnMut(&dyn Fn() -> String, Slot<'a>),
    ) {
        f(
            &|| format!("{}.samples", prefix()),
            Slot::Count(&mut self.samples),
        );
        for (k, c) in self.impacts.iter_mut().enumerate() {
            f(&|| format!("{}.impacts.{k}", prefix()), Slot::Count(c));
        }
        for (e, c) in Ending::ALL.iter().zip(self.endings.iter_mut()) {
            f(&|| format!("{}.{}", prefix(), e.name()), Slot::Count(c));
        }
        for (e, by) in Ending::ALL.iter().zip(self.by_ending.iter_mut()) {
            let at = || format!("{}.{}", prefix(), e.name());
            for (k, c) in by.axis_up.iter_mut().enumerate() {
                f(&|| format!("{}.axis_up.{k}", at()), Slot::Count(c));
            }
            f(
                &|| format!("{}.energy_left", at()),
                Slot::Moments(&mut by.energy_left),
            );
            f(&|| format!("{}.time", at()), Slot::Moments(&mut by.time));
        }
        for (k, c) in self.settled_on.iter_mut().enumerate() {
            f(&|| format!("{}.settled_on.{k}", prefix()), Slot::Count(c));
        }
        for (k, c) in self.sequences.iter_mut().enumerate() {
            f(&|| format!("{}.sequences.{k}", prefix()), Slot::Count(c));
        }
        for (name, c) in [
            ("reference_flights", &mut self.reference_flights),
            ("reference_impacts", &mut self.reference_impacts),
            ("lane_flights", &mut self.lane_flights),
            ("lane_poses", &mut self.lane_poses),
        ] {
            f(&|| format!("{}.{name}", prefix()), Slot::Count(c));
        }
        for (k, b) in self.bounces.iter_mut().enumerate() {
            let bounce = || format!("{}.bounce{}", prefix(), k + 1);
            for (name, c) in [
                ("reached", &mut b.reached),
                ("energy_gain", &mut b.energy_gain),
                ("degenerate", &mut b.degenerate),
            ] {
                f(&|| format!("{}.{name}", bounce()), Slot::Count(c));
            }
            for (m, c) in b.sets.iter_mut().enumerate() {
                f(&|| format!("{}.sets.{m}", bounce()), Slot::Count(c));
            }
            for (t, c) in b.within.iter_mut().enumerate() {
                f(&|| format!("{}.within.{t}", bounce()), Slot::Count(c));
            }
            for (name, m) in [
                ("energy_ratio", &mut b.energy_ratio),
                ("interval", &mut b.interval),
                ("speed_before", &mut b.speed_before),
            ] {
                f(&|| format!("{}.{name}", bounce()), Slot::Moments(m));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sequence_cells_round_trip() {
        for (planes, bounces) in [(1, 20), (3, 5), (3, 2), (4, 5), (6, 9)] {
            let acc = DropAcc::new(planes, bounces);
            let k = acc.sequence_impacts();
            assert!(acc.sequences.len() <= SEQUENCE_CELLS);
            assert_eq!(acc.sequences.len(), (1usize << planes).pow(k as u32));
            for cell in 0..acc.sequences.len() {
                let mut masks = acc.sequence_masks(cell);
                assert!(masks.len() <= k);
                masks.resize(k, 0);
                assert_eq!(acc.sequence_cell(&masks), cell, "{planes} planes");
            }
        }
        assert_eq!(DropAcc::new(3, 5).sequence_impacts(), 3);
        assert_eq!(DropAcc::new(3, 2).sequence_impacts(), 2);
        assert_eq!(DropAcc::new(6, 9).sequence_impacts(), 2);
    }
}
