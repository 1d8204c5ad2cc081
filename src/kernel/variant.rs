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
    /// Coulomb friction on a touching plane: the frictional kernel, which
    /// always has the lever arms and couples the contacts (Gauss–Seidel).
    pub friction: bool,
}

impl KernelVariant {
    /// The scene's variant, with the effects in `keep` compiled in whatever
    /// the scene needs.
    pub fn of(scene: &Scene, keep: Keep) -> Self {
        let e = scene.effects();
        // A drop scene's bounces are solved by the reference: its friction
        // does not reach the lane kernel.
        let friction = (e.friction || keep.friction) && scene.drop_box().is_none();
        Self {
            rotational_coupling: friction || keep.rotation || e.rotational_coupling,
            coupled_contacts: friction || keep.lcp || e.coupled_contacts,
            friction,
        }
    }

    /// `friction`, `rotation+lcp`, `rotation`, `lcp` or `closed-form`.
    pub fn name(&self) -> &'static str {
        if self.friction {
            return "friction";
        }
        match (self.rotational_coupling, self.coupled_contacts) {
            (true, true) => "rotation+lcp",
            (true, false) => "rotation",
            (false, true) => "lcp",
            (false, false) => "closed-form",
        }
    }
}
