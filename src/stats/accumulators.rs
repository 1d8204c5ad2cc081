//! Mergeable accumulators of a run: counts, moments and histograms per law,
//! per touching plane and per active set, and the paired differences
//! between laws. [`RunAcc::visit`] walks every field by a stable path; the
//! shard files store and restore accumulators through it.

use crate::stats::{LogHistogram, Moments, Stat};

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
    /// Per active set: moments of the three post-impact statistics.
    pub groups: Vec<GroupAcc>,
}

/// Paired differences `law − laws[0]` on the same impacting samples.
#[derive(Debug, Clone, Default)]
pub struct PairAcc {
    pub energy_ratio: Moments,
    pub omega_after_norm: Moments,
    pub velocity_after_norm: Moments,
}

#[derive(Debug, Clone)]
pub struct RunAcc {
    pub laws: Vec<LawAcc>,
    /// `pairs[i]` is laws[i + 1] − laws[0].
    pub pairs: Vec<PairAcc>,
}

impl LawAcc {
    fn new(contacts: usize) -> Self {
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
            groups: vec![GroupAcc::default(); 1 << contacts],
        }
    }

    fn flush(&mut self) {
        for s in [
            &mut self.energy_ratio,
            &mut self.omega_after_norm,
            &mut self.velocity_after_norm,
        ] {
            s.flush();
        }
        for s in &mut self.impulse {
            s.flush();
        }
        for m in &mut self.rebound {
            m.flush();
        }
        for g in &mut self.groups {
            g.energy_ratio.flush();
            g.omega_after_norm.flush();
            g.velocity_after_norm.flush();
        }
    }

    /// Back to the state of `new`, keeping the histograms' tables (the
    /// engine tests check every field through [`RunAcc::visit`]).
    fn clear(&mut self) {
        for c in [
            &mut self.samples,
            &mut self.impacts,
            &mut self.energy_gain,
            &mut self.degenerate,
            &mut self.jammed,
            &mut self.unsolved,
            &mut self.recomputed,
            &mut self.penetrating,
        ] {
            *c = 0;
        }
        self.active_sets.fill(0);
        let headline = [
            &mut self.energy_ratio,
            &mut self.omega_after_norm,
            &mut self.velocity_after_norm,
        ];
        for s in headline
            .into_iter()
            .chain(&mut self.impulse)
            .chain(&mut self.rebound)
        {
            s.clear();
        }
        for g in &mut self.groups {
            (g.samples, g.impacts) = (0, 0);
            g.energy_ratio.clear();
            g.omega_after_norm.clear();
            g.velocity_after_norm.clear();
        }
    }

    fn merge(&mut self, o: &LawAcc) {
        self.samples += o.samples;
        self.impacts += o.impacts;
        self.energy_gain += o.energy_gain;
        self.degenerate += o.degenerate;
        self.jammed += o.jammed;
        self.unsolved += o.unsolved;
        self.recomputed += o.recomputed;
        self.penetrating += o.penetrating;
        for (a, b) in self.active_sets.iter_mut().zip(&o.active_sets) {
            *a += b;
        }
        self.energy_ratio.merge(&o.energy_ratio);
        self.omega_after_norm.merge(&o.omega_after_norm);
        self.velocity_after_norm.merge(&o.velocity_after_norm);
        for (a, b) in self.impulse.iter_mut().zip(&o.impulse) {
            a.merge(b);
        }
        for (a, b) in self.rebound.iter_mut().zip(&o.rebound) {
            a.merge(b);
        }
        for (a, b) in self.groups.iter_mut().zip(&o.groups) {
            a.samples += b.samples;
            a.impacts += b.impacts;
            a.energy_ratio.merge(&b.energy_ratio);
            a.omega_after_norm.merge(&b.omega_after_norm);
            a.velocity_after_norm.merge(&b.velocity_after_norm);
        }
    }
}

impl RunAcc {
    pub fn new(laws: usize, contacts: usize) -> Self {
        Self {
            laws: (0..laws).map(|_| LawAcc::new(contacts)).collect(),
            pairs: vec![PairAcc::default(); laws.saturating_sub(1)],
        }
    }

    /// Back to the state of [`Self::new`], keeping the histograms' tables,
    /// so that a run reuses its batch accumulators instead of allocating
    /// (and page-faulting in) fresh ones per batch.
    pub fn clear(&mut self) {
        for l in &mut self.laws {
            l.clear();
        }
        self.pairs.fill(PairAcc::default());
    }

    pub fn flush(&mut self) {
        for l in &mut self.laws {
            l.flush();
        }
        for p in &mut self.pairs {
            p.energy_ratio.flush();
            p.omega_after_norm.flush();
            p.velocity_after_norm.flush();
        }
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

    /// Merges `o` after `self`; merging in a fixed order gives bit-identical
    /// results.
    pub fn merge(&mut self, o: &RunAcc) {
        for (a, b) in self.laws.iter_mut().zip(&o.laws) {
            a.merge(b);
        }
        for (a, b) in self.pairs.iter_mut().zip(&o.pairs) {
            a.energy_ratio.merge(&b.energy_ratio);
            a.omega_after_norm.merge(&b.omega_after_norm);
            a.velocity_after_norm.merge(&b.velocity_after_norm);
        }
    }
}

/// One accumulator field, as [`RunAcc::visit`] hands it out.
pub enum Slot<'a> {
    Count(&'a mut u64),
    Moments(&'a mut Moments),
    Histogram(&'a mut LogHistogram),
}

impl RunAcc {
    /// Every field with a stable path (`law0.groups.3.energy_ratio.hist`),
    /// in a fixed order: how shard files store and restore accumulators.
    pub fn visit(&mut self, f: &mut dyn FnMut(&str, Slot)) {
        fn stat(f: &mut dyn FnMut(&str, Slot), path: &str, s: &mut Stat) {
            f(&format!("{path}.moments"), Slot::Moments(&mut s.moments));
            f(&format!("{path}.hist"), Slot::Histogram(&mut s.hist));
        }
        for (li, l) in self.laws.iter_mut().enumerate() {
            let p = format!("law{li}");
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
                f(&format!("{p}.{name}"), Slot::Count(c));
            }
            for (m, c) in l.active_sets.iter_mut().enumerate() {
                f(&format!("{p}.active_sets.{m}"), Slot::Count(c));
            }
            stat(f, &format!("{p}.energy_ratio"), &mut l.energy_ratio);
            stat(f, &format!("{p}.omega_after_norm"), &mut l.omega_after_norm);
            stat(
                f,
                &format!("{p}.velocity_after_norm"),
                &mut l.velocity_after_norm,
            );
            for (i, s) in l.impulse.iter_mut().enumerate() {
                stat(f, &format!("{p}.impulse.{i}"), s);
            }
            for (i, s) in l.rebound.iter_mut().enumerate() {
                stat(f, &format!("{p}.rebound.{i}"), s);
            }
            for (m, g) in l.groups.iter_mut().enumerate() {
                let q = format!("{p}.groups.{m}");
                f(&format!("{q}.samples"), Slot::Count(&mut g.samples));
                f(&format!("{q}.impacts"), Slot::Count(&mut g.impacts));
                stat(f, &format!("{q}.energy_ratio"), &mut g.energy_ratio);
                stat(f, &format!("{q}.omega_after_norm"), &mut g.omega_after_norm);
                stat(
                    f,
                    &format!("{q}.velocity_after_norm"),
                    &mut g.velocity_after_norm,
                );
            }
        }
        for (pi, pa) in self.pairs.iter_mut().enumerate() {
            let p = format!("pair{}", pi + 1);
            f(
                &format!("{p}.energy_ratio"),
                Slot::Moments(&mut pa.energy_ratio),
            );
            f(
                &format!("{p}.omega_after_norm"),
                Slot::Moments(&mut pa.omega_after_norm),
            );
            f(
                &format!("{p}.velocity_after_norm"),
                Slot::Moments(&mut pa.velocity_after_norm),
            );
        }
    }
}
