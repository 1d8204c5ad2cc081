//! Drop studies, per sample: each sample is released from the scene's drop
//! box with its drawn orientation and velocities, flies under gravity with
//! torque-free rotation, hits the planes (time of impact by conservative
//! advancement), and bounces up to `effects.bounces` times or until its
//! kinetic energy after an impact falls below `effects.energy_floor` of the
//! kinetic energy it brought to its first impact.
//!
//! The engine runs drop batches like contact batches (same counter-based
//! draws, pool and merge tree, so the same shards, merges and thread
//! independence); this module is what one batch does: per sample, the f64
//! reference physics ([`crate::physics`]) for every law, recorded in the
//! run's accumulators (the first impact as a contact scene's impact, every
//! bounce in [`DropAcc`]) and, when asked for, one per-sample row per
//! impact.

use glam::DVec3;

use crate::config::{DropBox, Scene, Statistic};
use crate::lanes::Real;
use crate::output::samples::{DropRow, SampleRows};
use crate::physics::{
    solve_impact, time_of_impact, Ellipsoid, Impact, ImpactError, ImpactOutcome, Law, Motion,
    Plane, Pose, Rotation, State,
};
use crate::sampler::rng::CounterRng;
use crate::sampler::Sampler;
use crate::stats::accumulators::{LawAcc, PairAcc, RunAcc};
use crate::stats::drops::{DropAcc, Ending, SIMULTANEITY_TOLERANCES};
use crate::stats::Stat;

/// The start of sample `i`: drawn orientation and velocities, centre
/// uniform in the drop box (its own stream, so the engine's draws are
/// unchanged).
pub fn start_of(start: &DropBox, sampler: &Sampler, boxes: &CounterRng, i: u64) -> Motion {
    let (a, v, w) = sampler.reference(i);
    let (lo, hi) = (start.low, start.high);
    let u = DVec3::new(
        f64::uniform(boxes.bits(i, 0)),
        f64::uniform(boxes.bits(i, 1)),
        f64::uniform(boxes.bits(i, 2)),
    );
    Motion {
        centre: lo + (hi - lo) * u,
        rotation: a,
        velocity: v,
        omega: w,
    }
}

/// What every flight of a run shares, built once per run (not per sample).
pub struct Flight {
    planes: Vec<Plane>,
    gravity: DVec3,
    rotation: Rotation,
    toi_tolerance: f64,
    horizon: f64,
    /// Planes within this distance at the impact take part.
    contact_tolerance: f64,
}

/// Why a flight ended without a solved impact.
enum Stop {
    FlewAway,
    Unsolved,
}

impl Flight {
    /// The scene's flight with the given rotation and time-of-impact
    /// tolerance (a tolerance above the scene's contact tolerance widens it).
    pub fn new(scene: &Scene, rotation: Rotation, toi_tolerance: f64) -> Self {
        let fx = scene.effects();
        Self {
            planes: scene.planes().iter().map(|p| p.plane).collect(),
            gravity: DVec3::new(0.0, 0.0, -fx.gravity),
            rotation,
            toi_tolerance,
            horizon: fx.horizon,
            contact_tolerance: scene.tolerance().max(toi_tolerance),
        }
    }

    /// The scene's own rotation in flight (`effects.flight_rotation`).
    pub fn rotation_of(scene: &Scene) -> Rotation {
        let fx = scene.effects();
        if fx.flight_rotation == "rk4" {
            Rotation::Rk4 {
                max_step: fx.flight_step,
            }
        } else {
            Rotation::exact_for(scene.body())
        }
    }

    /// Flies from `m` to the next impact and solves it under `law`. An
    /// impact that touches several planes at once under `stronge` (defined
    /// for one contact) is solved by `newton` (friction.md), and the third
    /// value says so (`coupled_fallback`).
    fn next(
        &self,
        body: &Ellipsoid,
        m: &Motion,
        law: Law,
    ) -> Result<(Impact, ImpactOutcome, bool), Stop> {
        let hit = time_of_impact(
            body,
            m,
            &self.planes,
            self.gravity,
            self.rotation,
            self.toi_tolerance,
            self.horizon,
        )
        .ok_or(Stop::FlewAway)?;
        let pose = Pose {
            rotation: hit.motion.rotation,
            centre: hit.motion.centre,
        };
        let state = State {
            velocity: hit.motion.velocity,
            omega: hit.motion.omega,
        };
        let solve =
            |law| solve_impact(body, pose, state, &self.planes, law, self.contact_tolerance);
        match solve(law) {
            Ok(o) => Ok((hit, o, false)),
            Err(ImpactError::StrongeSeveral(_)) => solve(Law::Newton)
                .map(|o| (hit, o, true))
                .map_err(|_| Stop::Unsolved),
            Err(_) => Err(Stop::Unsolved),
        }
    }
}

/// What a drop batch needs, built once per run.
pub struct DropCtx<'a> {
    scene: &'a Scene,
    start: DropBox,
    sampler: Sampler,
    boxes: CounterRng,
    flight: Flight,
    quantiles: crate::config::Quantiles,
    by_set: bool,
}

impl<'a> DropCtx<'a> {
    pub fn new(scene: &'a Scene, start: DropBox, keep: crate::config::Keep) -> Self {
        let fx = scene.effects();
        let st = if keep.statistics {
            crate::config::Statistics::ALL
        } else {
            fx.statistics
        };
        Self {
            scene,
            start,
            sampler: Sampler::new(scene),
            boxes: crate::sampler::rng::drop_start_rng(scene.seed()),
            flight: Flight::new(scene, Flight::rotation_of(scene), fx.toi_tolerance),
            quantiles: st.quantiles,
            by_set: st.by_active_set,
        }
    }

    /// Samples `first..first + count` under every law, into `acc` (and one
    /// row per impact into `rows`).
    pub fn run(&self, first: u64, count: u64, acc: &mut RunAcc, mut rows: Option<&mut SampleRows>) {
        let laws = self.scene.laws();
        let mut firsts = vec![None; laws.len()];
        for i in first..first + count {
            let start = start_of(&self.start, &self.sampler, &self.boxes, i);
            for (l, &law) in laws.iter().enumerate() {
                let mut log = rows.as_deref_mut().map(|r| (r, i, l as u32));
                firsts[l] =
                    self.simulate(law, start, &mut acc.laws[l], &mut acc.drops[l], &mut log);
            }
            for (pair, other) in acc.pairs.iter_mut().zip(&firsts[1..]) {
                push_pair(pair, firsts[0].as_ref(), other.as_ref());
            }
        }
    }

    /// One sample under one law. Returns its first impact (none without
    /// one).
    fn simulate(
        &self,
        law: Law,
        start: Motion,
        la: &mut LawAcc,
        acc: &mut DropAcc,
        rows: &mut Option<(&mut SampleRows, u64, u32)>,
    ) -> Option<First> {
        let scene = self.scene;
        let fx = scene.effects();
        let body = scene.body();
        let bounces = fx.bounces as usize;
        // The energy floor is relative to the kinetic energy of the first impact.
        let mut t0 = f64::INFINITY;
        let mut m = start;
        let mut impacts = 0usize;
        let (mut since, mut clock) = (0.0, 0.0);
        let mut first = None;
        let mut masks = [0usize; crate::stats::drops::SEQUENCE_IMPACTS];
        acc.samples += 1;
        la.samples += 1;
        // A few non-impacts (a touch without approach) are tolerated per bounce.
        let mut attempts = 0;
        let ending = loop {
            if impacts == bounces {
                break Ending::BounceLimit;
            }
            if attempts == 4 * bounces + 4 {
                break Ending::Stalled;
            }
            attempts += 1;
            let (hit, o, coupled_fallback) = match self.flight.next(body, &m, law) {
                Ok(x) => x,
                Err(Stop::FlewAway) => break Ending::FlewAway,
                Err(Stop::Unsolved) => {
                    if impacts == 0 {
                        la.unsolved += 1;
                    }
                    break Ending::Unsolved;
                }
            };
            since += hit.time;
            clock += hit.time;
            m = hit.motion;
            let mask = o
                .contacts
                .iter()
                .enumerate()
                .filter(|(_, c)| c.impulse > 0.0)
                .fold(0usize, |s, (i, _)| s | 1 << i);
            if mask == 0 {
                // Touched without approaching: fly on.
                continue;
            }
            if impacts == 0 {
                t0 = o.energy_before;
                first = Some(First {
                    values: self.record_first(la, &hit.motion, &o, mask, coupled_fallback),
                    energy_gain: o.flags.energy_gain,
                });
            }
            if let Some(slot) = masks.get_mut(impacts) {
                *slot = mask;
            }
            let ratio = o.energy_after / o.energy_before;
            let b = &mut acc.bounces[impacts];
            b.reached += 1;
            b.sets[mask] += 1;
            b.energy_ratio.push(ratio);
            b.interval.push(since);
            b.speed_before.push(m.velocity.length());
            b.energy_gain += o.flags.energy_gain as u64;
            b.degenerate += o.flags.degenerate as u64;
            let second = second_smallest(&hit.distances);
            if let Some(second) = second {
                for (k, &tol) in SIMULTANEITY_TOLERANCES.iter().enumerate() {
                    b.within[k] += (second <= tol) as u64;
                }
            }
            if let Some((r, sample, law_index)) = rows.as_mut() {
                r.push_drop(&DropRow {
                    sample: *sample,
                    law: *law_index,
                    bounce: impacts as u32 + 1,
                    planes: mask as u32,
                    time: clock,
                    interval: since,
                    motion: &m,
                    outcome: &o,
                    distances: &hit.distances,
                });
            }
            impacts += 1;
            since = 0.0;
            m.velocity = o.after.velocity;
            m.omega = o.after.omega;
            if o.energy_after < fx.energy_floor * t0 {
                break Ending::CameToRest;
            }
        };
        if first.is_none() {
            la.active_sets[0] += 1;
            la.groups[0].samples += 1;
        }
        acc.endings[ending as usize] += 1;
        acc.impacts[impacts] += 1;
        let cell = acc.sequence_cell(&masks);
        acc.sequences[cell] += 1;
        // Which body axis is closest to vertical (world Z) at the end.
        let z = m.rotation.row(2).abs();
        let axis = if z.x >= z.y && z.x >= z.z {
            0
        } else if z.y >= z.z {
            1
        } else {
            2
        };
        acc.final_axis_up[axis] += 1;
        first
    }

    /// A first impact as a contact scene's impact: active set, headline
    /// statistics (histograms where the scene asks for quantiles), impulse
    /// and rebound per plane, flags.
    fn record_first(
        &self,
        la: &mut LawAcc,
        before: &Motion,
        o: &ImpactOutcome,
        mask: usize,
        coupled_fallback: bool,
    ) -> [f64; 3] {
        if let Some(fr) = &mut la.friction {
            let before = State {
                velocity: before.velocity,
                omega: before.omega,
            };
            let stuck_at =
                crate::physics::friction::sticking_threshold(self.scene.body(), &before, &o.after);
            fr.ambiguous += o.flags.ambiguous as u64;
            fr.unconverged += o.flags.unconverged as u64;
            fr.coupled_fallback += coupled_fallback as u64;
            for (i, c) in o.contacts.iter().enumerate() {
                let active = c.impulse > 0.0;
                fr.tangential_impulse[i]
                    .moments
                    .push(c.tangential_impulse.length());
                if active {
                    fr.sliding_speed[i].moments.push(c.sliding_after);
                }
                fr.active[i] += active as u64;
                fr.sticking[i] += (active && c.sliding_after <= stuck_at) as u64;
            }
        }
        let q = self.quantiles;
        let by_set = self.by_set;
        let values = [
            o.energy_after / o.energy_before,
            o.after.omega.length(),
            o.after.velocity.length(),
        ];
        la.impacts += 1;
        la.active_sets[mask] += 1;
        la.energy_gain += o.flags.energy_gain as u64;
        la.degenerate += o.flags.degenerate as u64;
        la.jammed += o.flags.jammed as u64;
        la.unsolved += o.flags.unsolved as u64;
        let g = &mut la.groups[mask];
        g.samples += 1;
        g.impacts += 1;
        let stats = [
            Statistic::EnergyRatio,
            Statistic::OmegaAfterNorm,
            Statistic::VelocityAfterNorm,
        ];
        let all = [
            &mut la.energy_ratio,
            &mut la.omega_after_norm,
            &mut la.velocity_after_norm,
        ];
        let group = [
            &mut g.energy_ratio,
            &mut g.omega_after_norm,
            &mut g.velocity_after_norm,
        ];
        for (((s, a), g), x) in stats.into_iter().zip(all).zip(group).zip(values) {
            a.moments.push(x);
            g.moments.push(x);
            if q.has(s) {
                // Summed into the "all" histograms by RunAcc::finish.
                if by_set {
                    g.hist.push(x);
                } else {
                    a.hist.push(x);
                }
            }
        }
        let push = |st: &mut Stat, x: f64, s: Statistic| {
            if q.has(s) {
                st.push(x);
            } else {
                st.moments.push(x);
            }
        };
        for (i, c) in o.contacts.iter().enumerate() {
            push(&mut la.impulse[i], c.impulse, Statistic::Impulse);
            if c.approaching {
                push(
                    &mut la.rebound[i],
                    -c.normal_velocity_after / c.normal_velocity_before,
                    Statistic::Rebound,
                );
                la.restitution[i].push(c.normal_velocity_after, -c.normal_velocity_before);
            }
        }
        values
    }
}

/// A sample's first impact under one law, as its pair statistics need it.
#[derive(Debug, Clone, Copy)]
struct First {
    /// Energy ratio, |ω⁺| and |v⁺|.
    values: [f64; 3],
    energy_gain: bool,
}

/// One sample's paired statistics, `other − base`, as a contact block
/// records them: differences where both laws impact, and the samples where
/// only one of the two raises `energy_gain`.
fn push_pair(p: &mut PairAcc, base: Option<&First>, other: Option<&First>) {
    let gains = |f: Option<&First>| f.is_some_and(|f| f.energy_gain);
    p.energy_gain_only += (gains(other) && !gains(base)) as u64;
    p.first_energy_gain_only += (gains(base) && !gains(other)) as u64;
    if let (Some(b), Some(o)) = (base, other) {
        p.energy_ratio.push(o.values[0] - b.values[0]);
        p.omega_after_norm.push(o.values[1] - b.values[1]);
        p.velocity_after_norm.push(o.values[2] - b.values[2]);
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

/// A sample's first impact with the given rotation in flight and
/// time-of-impact tolerance (for the accuracy ladder): the time from release and the post-impact velocities and energy
/// ratio. Planes within the larger of the contact and time-of-impact
/// tolerances take part. `None` if nothing is hit within the horizon, the
/// impact cannot be solved, or no plane takes an impulse.
pub fn first_impact(
    scene: &Scene,
    law: Law,
    start: &Motion,
    rotation: Rotation,
    toi_tolerance: f64,
) -> Option<(f64, DVec3, DVec3, f64)> {
    let (hit, o, _) = Flight::new(scene, rotation, toi_tolerance)
        .next(scene.body(), start, law)
        .ok()?;
    if o.contacts.iter().all(|c| c.impulse <= 0.0) {
        return None;
    }
    Some((
        hit.time,
        o.after.velocity,
        o.after.omega,
        o.energy_after / o.energy_before,
    ))
}
