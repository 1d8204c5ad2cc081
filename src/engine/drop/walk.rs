//! One sample's walk under one law: its flights and bounces until it comes
//! to rest, flies away, reaches the bounce limit or stalls, recorded in a
//! [`Log`] that is replayed into the accumulators in sample order. Flights
//! and impacts may be computed in any order and by any solver (the lanes
//! of [`super::wave`] or the reference); what a sample contributes, and in
//! which order, depends only on its index.

use crate::kernel::{Status, Strike};
use crate::output::columns::Field;
use crate::output::samples::SampleRows;
use crate::physics::{bryan_from_matrix, quaternion_from_matrix, Motion, State};
use crate::stats::accumulators::LawAcc;
use crate::stats::drops::{DropAcc, Ending, SEQUENCE_IMPACTS, SIMULTANEITY_TOLERANCES};

use super::ctx::Firsts;

/// Where a walk stands between flights.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Walk {
    /// Where the next flight starts.
    pub(crate) motion: Motion,
    /// The kinetic energy brought to the first impact (the energy floor is
    /// relative to it).
    t0: f64,
    impacts: usize,
    /// Time since the last impact, and since the release (s).
    since: f64,
    clock: f64,
    masks: [usize; SEQUENCE_IMPACTS],
    /// Flights flown: a few non-impacts (a touch without approach) are
    /// tolerated per bounce.
    attempts: usize,
    /// The walk's speed scale: the centre's speed at its first impact.
    scale: f64,
    /// The run of impacts on one plane alone whose approach speeds fall
    /// ([`SETTLE_RUN`]): the plane, its length and the last approach speed.
    run: (usize, usize, f64),
    /// Kinetic energy after the last impact (J).
    energy: f64,
    /// Where the walk settled, and when (s since release); whether it may
    /// (`effects.settle`).
    settled: Option<(usize, f64)>,
    may_settle: bool,
}

/// Impacts in a row on one plane alone, each approaching at most
/// [`SETTLE_RATIO`] as fast as the one before and slower than
/// [`SETTLE_FRACTION`] of the walk's speed scale, after which the walk is
/// taken to have settled on that plane: a Zeno sequence of bounces that
/// accumulates in finite time (a ball's on a floor: intervals 2eu/g
/// falling as eᵏ). At 1 % of the scale the bounces are still far above
/// what f32 lanes resolve (a bounce of drop_dice's rises some 2e-5 m,
/// against their 2e-7 m), so both precisions settle the same walks; at
/// 0.1 % they did not (43.9 % against 45.3 % of drop_dice's walks).
pub(crate) const SETTLE_RUN: usize = 5;
pub(crate) const SETTLE_RATIO: f64 = 0.99;
pub(crate) const SETTLE_FRACTION: f64 = 1e-2;

/// One bounce, as the bounce statistics read it.
#[derive(Debug, Clone, Copy)]
struct Bounce {
    mask: usize,
    ratio: f64,
    interval: f64,
    speed_before: f64,
    energy_gain: bool,
    degenerate: bool,
    /// The second-smallest plane distance (none with one plane).
    second: Option<f64>,
}

/// How an impact was solved.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct How {
    /// `stronge` on several planes, solved by `newton`.
    pub(crate) coupled_fallback: bool,
    /// By the f64 reference, where lanes flagged it.
    pub(crate) recomputed: bool,
}

/// The sample's first impact, for the block statistics. (Logs are reused
/// from chunk to chunk; a boxed strike would be an allocation per walk.)
#[derive(Debug, Clone, Copy)]
#[allow(clippy::large_enum_variant)]
enum First {
    None,
    Unsolved,
    Impact {
        strike: Strike,
        before: State,
        how: How,
    },
}

/// What a walk recorded.
#[derive(Debug, Clone)]
pub(crate) struct Log {
    bounces: Vec<Bounce>,
    /// With per-impact rows: the motion at each impact, its strike, the
    /// time from release and the interval since the last impact.
    rows: Vec<(Motion, Strike, f64, f64)>,
    keep_rows: bool,
    first: First,
    /// Flights and impacts the lanes left to the f64 reference.
    pub(crate) reference_flights: u32,
    pub(crate) reference_impacts: u32,
    /// Flights searched in lanes, and the poses those searches evaluated
    /// in the walk's own lane (one per step and one where it stopped).
    pub(crate) lane_flights: u32,
    pub(crate) lane_poses: u32,
    ending: Ending,
    impacts: usize,
    masks: [usize; SEQUENCE_IMPACTS],
    /// The body axis closest to vertical at the end.
    axis_up: usize,
    /// Kinetic energy left and time since release at the end, and the
    /// plane settled on.
    energy_left: f64,
    end_time: f64,
    settled_on: Option<usize>,
}

impl Log {
    pub(crate) fn new(keep_rows: bool) -> Self {
        Self {
            bounces: Vec::new(),
            rows: Vec::new(),
            keep_rows,
            first: First::None,
            reference_flights: 0,
            reference_impacts: 0,
            lane_flights: 0,
            lane_poses: 0,
            ending: Ending::BounceLimit,
            impacts: 0,
            masks: [0; SEQUENCE_IMPACTS],
            axis_up: 0,
            energy_left: 0.0,
            end_time: 0.0,
            settled_on: None,
        }
    }

    /// Empties the log for the next walk.
    pub(crate) fn clear(&mut self) {
        self.bounces.clear();
        self.rows.clear();
        self.first = First::None;
        self.reference_flights = 0;
        self.reference_impacts = 0;
        self.lane_flights = 0;
        self.lane_poses = 0;
    }

    /// Replays the walk of sample `sample` under law `law` into its
    /// accumulators, its first impact into lane `s` of `first` and its
    /// impacts into `rows`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn replay<const N: usize>(
        &self,
        (sample, law): (u64, u32),
        s: usize,
        first: &mut Firsts<'_, N>,
        body: &crate::physics::Ellipsoid,
        la: &mut LawAcc,
        acc: &mut DropAcc,
        rows: Option<&mut SampleRows>,
    ) {
        acc.samples += 1;
        match &self.first {
            First::None => first.none(s, Status::NONE),
            First::Unsolved => first.none(s, Status::UNSOLVED),
            First::Impact {
                strike,
                before,
                how,
            } => {
                let status = Status::when(how.recomputed, Status::RECOMPUTED);
                first.impact(s, body, before, strike, status);
                if let Some(fr) = la.friction.as_mut() {
                    fr.coupled_fallback += how.coupled_fallback as u64;
                }
            }
        }
        for (k, b) in self.bounces.iter().enumerate() {
            let r = &mut acc.bounces[k];
            r.reached += 1;
            r.sets[b.mask] += 1;
            r.energy_ratio.push(b.ratio);
            r.interval.push(b.interval);
            r.speed_before.push(b.speed_before);
            r.energy_gain += b.energy_gain as u64;
            r.degenerate += b.degenerate as u64;
            if let Some(second) = b.second {
                for (j, &tol) in SIMULTANEITY_TOLERANCES.iter().enumerate() {
                    r.within[j] += (second <= tol) as u64;
                }
            }
        }
        if let Some(out) = rows {
            for (k, (motion, strike, time, interval)) in self.rows.iter().enumerate() {
                push_drop(
                    out,
                    &DropRow {
                        sample,
                        law,
                        bounce: k as u32 + 1,
                        planes: strike.mask() as u32,
                        time: *time,
                        interval: *interval,
                        motion,
                        strike,
                    },
                );
            }
        }
        acc.reference_flights += self.reference_flights as u64;
        acc.reference_impacts += self.reference_impacts as u64;
        acc.lane_flights += self.lane_flights as u64;
        acc.lane_poses += self.lane_poses as u64;
        acc.endings[self.ending as usize] += 1;
        let by = &mut acc.by_ending[self.ending as usize];
        by.axis_up[self.axis_up] += 1;
        by.energy_left.push(self.energy_left);
        by.time.push(self.end_time);
        if let Some(p) = self.settled_on {
            acc.settled_on[p] += 1;
        }
        acc.impacts[self.impacts] += 1;
        let cell = acc.sequence_cell(&self.masks);
        acc.sequences[cell] += 1;
    }
}

impl Walk {
    /// A walk released at `start` with kinetic energy `energy` (J), that
    /// may end as settled or not.
    pub(crate) fn new(start: Motion, energy: f64, may_settle: bool) -> Self {
        Self {
            motion: start,
            t0: f64::INFINITY,
            impacts: 0,
            since: 0.0,
            clock: 0.0,
            masks: [0; SEQUENCE_IMPACTS],
            attempts: 0,
            scale: 0.0,
            run: (usize::MAX, 0, f64::INFINITY),
            energy,
            settled: None,
            may_settle,
        }
    }

    /// Before a flight: the ending if the walk is over (the bounce limit,
    /// or too many flights without an impact), else `None` and the flight
    /// is counted.
    pub(crate) fn fly(&mut self, bounces: usize) -> Option<Ending> {
        if self.impacts == bounces {
            return Some(Ending::BounceLimit);
        }
        if self.attempts == 4 * bounces + 4 {
            return Some(Ending::Stalled);
        }
        self.attempts += 1;
        None
    }

    /// The flight ended `time` after its start at `motion` (the state just
    /// before the impact) with `strike`. The ending if the walk is over
    /// (its energy fell below `floor` of the first impact's), else `None`
    /// and the next flight starts from the state after the impact (or, if
    /// no plane took an impulse, from `motion`).
    pub(crate) fn struck(
        &mut self,
        time: f64,
        motion: Motion,
        strike: &Strike,
        how: How,
        floor: f64,
        log: &mut Log,
    ) -> Option<Ending> {
        self.since += time;
        self.clock += time;
        self.motion = motion;
        let mask = strike.mask();
        if mask == 0 {
            // Touched without approaching: fly on.
            return None;
        }
        if self.impacts == 0 {
            self.t0 = strike.energy_before;
            log.first = First::Impact {
                strike: *strike,
                before: State {
                    velocity: motion.velocity,
                    omega: motion.omega,
                },
                how,
            };
        }
        if let Some(slot) = self.masks.get_mut(self.impacts) {
            *slot = mask;
        }
        log.bounces.push(Bounce {
            mask,
            ratio: strike.energy_after / strike.energy_before,
            interval: self.since,
            speed_before: motion.velocity.length(),
            energy_gain: strike.flags.energy_gain,
            degenerate: strike.flags.degenerate,
            second: second_smallest(strike.distances()),
        });
        if log.keep_rows {
            log.rows.push((motion, *strike, self.clock, self.since));
        }
        if self.impacts == 0 {
            self.scale = motion.velocity.length();
        }
        let interval = self.since;
        self.impacts += 1;
        self.since = 0.0;
        self.motion.velocity = strike.after.velocity;
        self.motion.omega = strike.after.omega;
        self.energy = strike.energy_after;
        if strike.energy_after < floor * self.t0 {
            return Some(Ending::CameToRest);
        }
        self.settles(mask, strike, interval)
    }

    /// After an impact on the planes `mask`, `interval` after the one
    /// before: `Settled` if it ends a run of [`SETTLE_RUN`] on one plane
    /// alone with approach speeds u falling by at least [`SETTLE_RATIO`]
    /// and below [`SETTLE_FRACTION`] of the speed scale. The bounces then
    /// accumulate: with ρ = uₖ/uₖ₋₁ the intervals fall like ρ too (a
    /// flight's time is proportional to the speed it leaves with), so the
    /// rest of them add up to interval·ρ/(1 − ρ), the time the walk settles
    /// at. For a ball bouncing on a floor with restitution e this is exact
    /// (ρ = e, the closed form's 2eu/(g(1 − e))); for a rocking body it
    /// extrapolates its last two bounces.
    fn settles(&mut self, mask: usize, strike: &Strike, interval: f64) -> Option<Ending> {
        let single = mask.count_ones() == 1;
        let plane = mask.trailing_zeros() as usize;
        let u = -strike.normal_velocity_before[plane];
        let (p, n, last) = self.run;
        let falling = single && p == plane && u <= SETTLE_RATIO * last;
        let slow = u < SETTLE_FRACTION * self.scale;
        self.run = match (single, falling && slow) {
            (false, _) => (usize::MAX, 0, f64::INFINITY),
            (true, true) => (plane, n + 1, u),
            (true, false) => (plane, slow as usize, u),
        };
        if self.run.1 < SETTLE_RUN || !self.may_settle {
            return None;
        }
        let rho = u / last;
        self.settled = Some((plane, self.clock + interval * rho / (1.0 - rho)));
        Some(Ending::Settled)
    }

    /// The impact could not be solved: the walk ends.
    pub(crate) fn unsolved(&self, log: &mut Log) -> Ending {
        if self.impacts == 0 {
            log.first = First::Unsolved;
        }
        Ending::Unsolved
    }

    /// The walk ended: its ending, impacts, sequence and final attitude
    /// into `log`.
    pub(crate) fn finish(&self, ending: Ending, log: &mut Log) {
        log.ending = ending;
        log.impacts = self.impacts;
        log.masks = self.masks;
        log.energy_left = self.energy;
        (log.settled_on, log.end_time) = match self.settled {
            Some((plane, time)) if ending == Ending::Settled => (Some(plane), time),
            _ => (None, self.clock - self.since),
        };
        // Which body axis is closest to vertical (world Z) at the end.
        let z = self.motion.rotation.row(2).abs();
        log.axis_up = if z.x >= z.y && z.x >= z.z {
            0
        } else if z.y >= z.z {
            1
        } else {
            2
        };
    }
}

/// The second-smallest of the planes' distances (none with one plane).
fn second_smallest(d: &[f64]) -> Option<f64> {
    let (mut a, mut b) = (f64::INFINITY, f64::INFINITY);
    for &x in d {
        if x < a {
            b = a;
            a = x;
        } else if x < b {
            b = x;
        }
    }
    (d.len() > 1).then_some(b)
}

/// One impact of a drop sample, as [`push_drop`] writes it.
struct DropRow<'a> {
    sample: u64,
    law: u32,
    bounce: u32,
    planes: u32,
    time: f64,
    interval: f64,
    /// At the moment of impact, before it.
    motion: &'a Motion,
    strike: &'a Strike,
}

/// Appends one impact: each column of the drop
/// [`RowLayout`](crate::output::columns::RowLayout) gets the value its
/// [`Field`] names.
fn push_drop(rows: &mut SampleRows, r: &DropRow) {
    rows.index.push(r.sample);
    rows.law.push(r.law);
    let m = r.motion;
    let o = r.strike;
    let q = quaternion_from_matrix(m.rotation);
    let q = [q.w, q.x, q.y, q.z];
    let bryan = if rows.fills_any(|f| matches!(f, Field::Bryan(_))) {
        bryan_from_matrix(m.rotation).degrees()
    } else {
        [f64::NAN; 3]
    };
    for (k, field) in rows.float_fields().iter().enumerate() {
        let v = match *field {
            Field::Time => r.time,
            Field::Interval => r.interval,
            Field::Centre(c) => m.centre[c],
            Field::Quaternion(c) => q[c],
            Field::Bryan(c) => bryan[c],
            Field::Velocity(c) => m.velocity[c],
            Field::Omega(c) => m.omega[c],
            Field::EnergyBefore => o.energy_before,
            Field::EnergyAfter { .. } => o.energy_after,
            Field::EnergyRatio { .. } => o.energy_after / o.energy_before,
            Field::VelocityAfter { axis, .. } => o.after.velocity[axis],
            Field::OmegaAfter { axis, .. } => o.after.omega[axis],
            Field::Distance { plane } => o.distance[plane],
            Field::VnBefore { plane } => o.normal_velocity_before[plane],
            Field::VnAfter { plane, .. } => o.contacts[plane].normal_velocity_after,
            Field::Impulse { plane, .. } => o.contacts[plane].impulse,
            f => unreachable!("{f:?} is not a drop row's float column"),
        };
        rows.put(k, std::iter::once(v));
    }
    for (k, field) in rows.int_fields().iter().enumerate() {
        // Bounces are at most 10,000 and planes at most six; the drop
        // reference raises energy_gain, degenerate, jammed and unsolved,
        // whose bits end at bit 12.
        let v = match *field {
            Field::Bounce => r.bounce,
            Field::Planes => r.planes,
            Field::Flags { .. } => o.flags.to_bits().bits(),
            f => unreachable!("{f:?} is not a drop row's integer column"),
        };
        rows.ints[k].push(v as u16);
    }
}
