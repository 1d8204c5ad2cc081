//! The kernel instantiation a run uses.

use crate::config::{Keep, Scene};

/// The kernel instantiation a run uses, chosen once per run from the scene's
/// derived effects: each effect a scene does not need is compiled out of
/// its kernel (const generics), not branched over per sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct KernelVariant {
    /// Lever arms, per-lane G and ω⁺ (off for spheres).
    pub rotational_coupling: bool,
    /// The LCP over the touching planes (off for one plane, or G diagonal
    /// by geometry: every law is then the per-contact closed form).
    pub coupled_contacts: bool,
}

impl KernelVariant {
    /// The scene's variant, with the effects in `keep` compiled in whatever
    /// the scene needs.
    pub fn of(scene: &Scene, keep: Keep) -> Self {
        let e = scene.effects();
        Self {
            rotational_coupling: keep.rotation || e.rotational_coupling,
            coupled_contacts: keep.lcp || e.coupled_contacts,
        }
    }

    /// `rotation+lcp`, `rotation`, `lcp` or `closed-form`.
    pub fn name(&self) -> &'static str {
        match (self.rotational_coupling, self.coupled_contacts) {
            (true, true) => "rotation+lcp",
            (true, false) => "rotation",
            (false, true) => "lcp",
            (false, false) => "closed-form",
        }
    }
}
