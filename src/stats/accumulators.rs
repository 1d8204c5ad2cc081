//! Mergeable accumulators of a run: counts, moments and histograms per law,
//! per touching plane and per active set, and the paired differences
//! between laws, and a drop study's per-law [`DropAcc`]. [`RunAcc::visit`]
//! walks every field by a stable path; the shard files store and restore
//! accumulators through it.

use crate::config::Scene;
use crate::stats::drops::DropAcc;
use crate::stats::{Moments, RatioOfSums, Slot, Stat};

/// Statistics of the samples in one active-contact set.
#[derive(Debug, Clone, Default)]
pub struct GroupAcc {
    pub samples: u64,
    pub impacts: u64,
    pub energy_ratio: Stat,
    pub omega_after_norm: Stat,
    pub velocity_after_norm: Stat,
}

/// Everything accumulated for one law.
#[derive(Debug, Clone)]
pub struct LawAcc {
    pub samples: u64,
    pub impacts: u64,
    pub energy_gain: u64,
    pub degenerate: u64,
    pub jammed: u64,
    pub unsolved: u64,
    pub recomputed: u64,
    pub penetrating: u64,
    /// Counts per active set (bit i: touching plane i took λ > 0), all samples.
    pub active_sets: Vec<u64>,
    /// Over impacting samples. Their histograms are filled per contact set
    /// (each impacting sample is in exactly one) and summed into these by
    /// [`RunAcc::finish`].
    pub energy_ratio: Stat,
    pub omega_after_norm: Stat,
    pub velocity_after_norm: Stat,
    /// Per touching plane, over impacting samples (zeros included).
    pub impulse: Vec<Stat>,
    /// Per touching plane, `−v_n⁺/v_n⁻` over samples where it approached.
    pub rebound: Vec<Stat>,
    /// Per touching plane, `Σ v_n⁺ / Σ |v_n⁻|` over the same samples.
    pub restitution: Vec<RatioOfSums>,
    /// Per active set: moments of the three post-impact statistics.
    pub groups: Vec<GroupAcc>,
    /// Friction statistics, in scenes with friction only.
    pub friction: Option<FrictionAcc>,
}

/// One law's friction statistics (friction.md, "What the engine reports").
#[derive(Debug, Clone, Default)]
pub struct FrictionAcc {
    /// Samples with several valid single-contact solutions, and samples
    /// where neither Gauss–Seidel converged.
    pub ambiguous: u64,
    pub unconverged: u64,
    /// Impacts that touched several planes at once under `stronge` (a drop
    /// scene's first impact), solved by `newton` instead.
    pub coupled_fallback: u64,
    /// Per touching plane, over impacting samples (zeros included): |f|.
    pub tangential_impulse: Vec<Stat>,
    /// Per touching plane, over its active contacts (λ > 0): `|c⁺_t|`.
    pub sliding_speed: Vec<Stat>,
    /// Per touching plane: active contacts, and those that end sticking.
    pub active: Vec<u64>,
    pub sticking: Vec<u64>,
}

impl FrictionAcc {
    fn new(contacts: usize) -> Self {
        Self {
            tangential_impulse: vec![Stat::default(); contacts],
            sliding_speed: vec![Stat::default(); contacts],
            active: vec![0; contacts],
            sticking: vec![0; contacts],
            ..Self::default()
        }
    }
}

/// Paired differences `law − laws[0]` on the same impacting samples.
#[derive(Debug, Clone, Default)]
pub struct PairAcc {
    pub energy_ratio: Moments,
    pub omega_after_norm: Moments,
    pub velocity_after_norm: Moments,
    /// Contact scenes: samples where this law raises `energy_gain` and
    /// `laws[0]` does not, and the other way round (with friction, how often
    /// `newton` commits Kane's paradox where `stronge` does not).
    pub energy_gain_only: u64,
    pub first_energy_gain_only: u64,
}

#[derive(Debug, Clone)]
pub struct RunAcc {
    /// A contact scene's impact, or a drop scene's first impact, per law.
    pub laws: Vec<LawAcc>,
    /// `pairs[i]` is `laws[i + 1]` − `laws[0]`.
    pub pairs: Vec<PairAcc>,
    /// A drop scene's bounces, per law (empty for a contact scene).
    pub drops: Vec<DropAcc>,
}

/// The shape of a run's accumulators: what a fresh or restored one holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shape {
    pub laws: usize,
    /// Planes per active set: the touching planes of a contact scene, every
    /// plane of a drop scene.
    pub contacts: usize,
    /// `effects.bounces` of a drop scene; 0 for a contact scene.
    pub bounces: usize,
    /// Friction statistics are kept (a scene with friction; a drop scene
    /// keeps them of its first impact).
    pub friction: bool,
}

impl Shape {
    pub fn of(scene: &Scene) -> Self {
        Self {
            laws: scene.laws().len(),
            contacts: scene.recorded_planes().len(),
            bounces: scene.recorded_bounces(),
            friction: scene.effects().friction,
        }
    }
}

impl LawAcc {
    fn new(contacts: usize, friction: bool) -> Self {
        Self {
            samples: 0,
            impacts: 0,
            energy_gain: 0,
            degenerate: 0,
            jammed: 0,
            unsolved: 0,
            recomputed: 0,
            penetrating: 0,
            active_sets: vec![0; 1 << contacts],
            energy_ratio: Stat::default(),
            omega_after_norm: Stat::default(),
            velocity_after_norm: Stat::default(),
            impulse: vec![Stat::default(); contacts],
            rebound: vec![Stat::default(); contacts],
            restitution: vec![RatioOfSums::default(); contacts],
            groups: vec![GroupAcc::default(); 1 << contacts],
            friction: friction.then(|| FrictionAcc::new(contacts)),
        }
    }
}

impl RunAcc {
    /// A contact scene's accumulators.
    pub fn new(laws: usize, contacts: usize) -> Self {
        Self::shaped(Shape {
            laws,
            contacts,
            bounces: 0,
            friction: false,
        })
    }

    pub fn shaped(shape: Shape) -> Self {
        let Shape {
            laws,
            contacts,
            bounces,
            friction,
        } = shape;
        Self {
            laws: (0..laws).map(|_| LawAcc::new(contacts, friction)).collect(),
            pairs: vec![PairAcc::default(); laws.saturating_sub(1)],
            drops: if bounces == 0 {
                Vec::new()
            } else {
                (0..laws).map(|_| DropAcc::new(contacts, bounces)).collect()
            },
        }
    }

    /// Back to the state of [`Self::new`], keeping the histograms' tables,
    /// so that a run reuses its batch accumulators instead of allocating
    /// (and page-faulting in) fresh ones per batch.
    pub fn clear(&mut self) {
        self.walk(&mut |_, slot| match slot {
            Slot::Count(c) => *c = 0,
            Slot::Moments(m) => *m = Moments::default(),
            Slot::Histogram(h) => h.clear(),
        });
    }

    /// Folds every moment's pending block sums into its state (once per
    /// batch).
    pub fn flush(&mut self) {
        self.walk(&mut |_, slot| {
            if let Slot::Moments(m) = slot {
                m.flush();
            }
        });
    }

    /// Completes a run's accumulators: the "all" histograms are the sums of
    /// the contact sets' (in set order).
    pub fn finish(&mut self) {
        for l in &mut self.laws {
            for g in &l.groups {
                l.energy_ratio.hist.merge(&g.energy_ratio.hist);
                l.omega_after_norm.hist.merge(&g.omega_after_norm.hist);
                l.velocity_after_norm
                    .hist
                    .merge(&g.velocity_after_norm.hist);
            }
        }
    }

    /// Merges `o` after `self`, field by field; merging in a fixed order
    /// gives bit-identical results. `o` is only read (it is walked mutably
    /// because [`Self::walk`] hands out mutable fields).
    pub fn merge(&mut self, o: &mut RunAcc) {
        let mut theirs = Vec::with_capacity(128);
        o.walk(&mut |_, slot| theirs.push(slot));
        let mut theirs = theirs.into_iter();
        self.walk(&mut |path, mine| match (mine, theirs.next()) {
            (Slot::Count(a), Some(Slot::Count(b))) => *a += *b,
            (Slot::Moments(a), Some(Slot::Moments(b))) => a.merge(b),
            (Slot::Histogram(a), Some(Slot::Histogram(b))) => a.merge(b),
            _ => panic!("merging accumulators of different shapes at {}", path()),
        });
    }
}

impl RunAcc {
    /// Every field with a stable path (`law0.groups.3.energy_ratio.hist`),
    /// in a fixed order: how shard files store and restore accumulators.
    pub fn visit(&mut self, f: &mut dyn FnMut(&str, Slot)) {
        self.walk(&mut |path, slot| f(&path(), slot));
    }

    /// The one walk over every field, in [`Self::visit`]'s order, that
    /// clearing, flushing, merging and the shard files are built on. Each
    /// field comes with its path, made only when asked for.
    fn walk<'a>(&'a mut self, f: &mut dyn FnMut(&dyn Fn() -> String, Slot<'a>)) {
        fn stat<'a>(
            f: &mut dyn FnMut(&dyn Fn() -> String, Slot<'a>),
            path: &dyn Fn() -> String,
            s: &'a mut Stat,
        ) {
            f(
                &|| format!("{}.moments", path()),
                Slot::Moments(&mut s.moments),
            );
            f(&|| format!("{}.hist", path()), Slot::Histogram(&mut s.hist));
        }
        for (li, l) in self.laws.iter_mut().enumerate() {
            let law = || format!("law{li}");
            for (name, c) in [
                ("samples", &mut l.samples),
                ("impacts", &mut l.impacts),
                ("energy_gain", &mut l.energy_gain),
                ("degenerate", &mut l.degenerate),
                ("jammed", &mut l.jammed),
                ("unsolved", &mut l.unsolved),
                ("recomputed", &mut l.recomputed),
                ("penetrating", &mut l.penetrating),
            ] {
                f(&|| format!("{}.{name}", law()), Slot::Count(c));
            }
            for (m, c) in l.active_sets.iter_mut().enumerate() {
                f(&|| format!("{}.active_sets.{m}", law()), Slot::Count(c));
            }
            let headline = [
                ("energy_ratio", &mut l.energy_ratio),
                ("omega_after_norm", &mut l.omega_after_norm),
                ("velocity_after_norm", &mut l.velocity_after_norm),
            ];
            for (name, s) in headline {
                stat(f, &|| format!("{}.{name}", law()), s);
            }
            for (i, s) in l.impulse.iter_mut().enumerate() {
                stat(f, &|| format!("{}.impulse.{i}", law()), s);
            }
            for (i, s) in l.rebound.iter_mut().enumerate() {
                stat(f, &|| format!("{}.rebound.{i}", law()), s);
            }
            for (i, r) in l.restitution.iter_mut().enumerate() {
                let parts = [
                    ("resid", &mut r.resid),
                    ("y", &mut r.y),
                    ("sum", &mut r.sum),
                ];
                for (part, m) in parts {
                    f(
                        &|| format!("{}.restitution.{i}.{part}", law()),
                        Slot::Moments(m),
                    );
                }
            }
            if let Some(fr) = &mut l.friction {
                let friction = || format!("{}.friction", law());
                f(
                    &|| format!("{}.ambiguous", friction()),
                    Slot::Count(&mut fr.ambiguous),
                );
                f(
                    &|| format!("{}.unconverged", friction()),
                    Slot::Count(&mut fr.unconverged),
                );
                f(
                    &|| format!("{}.coupled_fallback", friction()),
                    Slot::Count(&mut fr.coupled_fallback),
                );
                for (i, s) in fr.tangential_impulse.iter_mut().enumerate() {
                    stat(f, &|| format!("{}.tangential_impulse.{i}", friction()), s);
                }
                for (i, s) in fr.sliding_speed.iter_mut().enumerate() {
                    stat(f, &|| format!("{}.sliding_speed.{i}", friction()), s);
                }
                for (i, c) in fr.active.iter_mut().enumerate() {
                    f(&|| format!("{}.active.{i}", friction()), Slot::Count(c));
                }
                for (i, c) in fr.sticking.iter_mut().enumerate() {
                    f(&|| format!("{}.sticking.{i}", friction()), Slot::Count(c));
                }
            }
            for (m, g) in l.groups.iter_mut().enumerate() {
                let group = || format!("{}.groups.{m}", law());
                f(
                    &|| format!("{}.samples", group()),
                    Slot::Count(&mut g.samples),
                );
                f(
                    &|| format!("{}.impacts", group()),
                    Slot::Count(&mut g.impacts),
                );
                let headline = [
                    ("energy_ratio", &mut g.energy_ratio),
                    ("omega_after_norm", &mut g.omega_after_norm),
                    ("velocity_after_norm", &mut g.velocity_after_norm),
                ];
                for (name, s) in headline {
                    stat(f, &|| format!("{}.{name}", group()), s);
                }
            }
        }
        for (pi, pa) in self.pairs.iter_mut().enumerate() {
            let headline = [
                ("energy_ratio", &mut pa.energy_ratio),
                ("omega_after_norm", &mut pa.omega_after_norm),
                ("velocity_after_norm", &mut pa.velocity_after_norm),
            ];
            for (name, m) in headline {
                f(&|| format!("pair{}.{name}", pi + 1), Slot::Moments(m));
            }
            f(
                &|| format!("pair{}.energy_gain_only", pi + 1),
                Slot::Count(&mut pa.energy_gain_only),
            );
            f(
                &|| format!("pair{}.first_energy_gain_only", pi + 1),
                Slot::Count(&mut pa.first_energy_gain_only),
            );
        }
        for (li, d) in self.drops.iter_mut().enumerate() {
            d.walk(&|| format!("drop{li}"), f);
        }
    }
}
