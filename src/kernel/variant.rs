//! The kernel instantiation a run uses.

use crate::config::{Keep, Scene};

/// The kernel instantiation a run uses, chosen once per run from the scene's
/// derived effects: each effect a scene does not need is compiled out of
/// its kernel (const generics), not branched over per sample. It is the one
/// place that says whether the kernel is frictional.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum KernelVariant {
    /// Normal impulses only.
    Frictionless {
        /// Lever arms, per-lane G and ω⁺ (off for spheres).
        rotational_coupling: bool,
        /// The LCP over the touching planes (off for one plane, or G
        /// diagonal by geometry: every law is then the per-contact closed
        /// form).
        coupled_contacts: bool,
    },
    /// Coulomb friction on a touching plane: contact frames, the
    /// single-contact solve and Gauss–Seidel over the contacts. Lever arms
    /// and coupling are part of it.
    Frictional,
}

impl KernelVariant {
    /// The frictionless variant with every effect compiled in.
    pub const ALL_FRICTIONLESS: Self = Self::Frictionless {
        rotational_coupling: true,
        coupled_contacts: true,
    };

    /// The scene's variant, with the effects in `keep` compiled in whatever
    /// the scene needs.
    pub fn of(scene: &Scene, keep: Keep) -> Self {
        let e = scene.effects();
        if e.friction || keep.friction {
            return Self::Frictional;
        }
        Self::Frictionless {
            rotational_coupling: keep.rotation || e.rotational_coupling,
            coupled_contacts: keep.lcp || e.coupled_contacts,
        }
    }

    /// Whether this is the frictional kernel.
    pub fn frictional(&self) -> bool {
        matches!(self, Self::Frictional)
    }

    /// `friction`, `rotation+lcp`, `rotation`, `lcp` or `closed-form`.
    pub fn name(&self) -> &'static str {
        match *self {
            Self::Frictional => "friction",
            Self::Frictionless {
                rotational_coupling,
                coupled_contacts,
            } => match (rotational_coupling, coupled_contacts) {
                (true, true) => "rotation+lcp",
                (true, false) => "rotation",
                (false, true) => "lcp",
                (false, false) => "closed-form",
            },
        }
    }
}
