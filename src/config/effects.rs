//! The effects a scene calls for, declared or derived: what the kernel
//! computes and what the statistics keep.

use glam::DVec3;

use crate::config::bad::{bad, Bad};
use crate::config::plane::NamedPlane;
use crate::config::{RawScene, RawVector};
use crate::physics::Ellipsoid;

/// What a scene simulates: the effects it declares (`[effects]`, the
/// placement) and those derived from its geometry. Printed at the start of a
/// run and stored in the manifest.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Effects {
    /// Rotation couples to the impulse (false for spheres: ρ = 0, ω is
    /// untouched by impacts).
    pub rotational_coupling: bool,
    /// An LCP couples the contacts (false with one touching plane, or when
    /// G is diagonal by geometry: a sphere on mutually orthogonal planes).
    pub coupled_contacts: bool,
    /// Coulomb friction on a plane that can take an impact (a touching
    /// plane; any plane of a drop scene).
    pub friction: bool,
    /// Flight under gravity before and between impacts.
    pub flight: bool,
    pub gravity: f64,
    /// Impacts followed per sample.
    pub bounces: u32,
    pub energy_floor: f64,
    /// Walks whose bounces on one plane accumulate end as settled on it.
    pub settle: bool,
    pub flight_step: f64,
    pub toi_tolerance: f64,
    pub horizon: f64,
    /// Torque-free rotation in flight: "none", "precession" (exact, a = b),
    /// "elliptic" (exact, triaxial) or "rk4" (asked for, with
    /// `flight_step`).
    pub flight_rotation: &'static str,
    /// Per-sample rows requested.
    pub per_sample: bool,
    /// Statistics kept beyond counts and moments (`[statistics]`).
    pub statistics: Statistics,
    /// |ω⁺|, when it is the same in every sample (no rotational coupling and
    /// a fixed ω): counted, not computed per sample.
    pub constant_spin: Option<f64>,
}

/// A statistic that can keep quantiles (`[statistics] quantiles`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Statistic {
    /// T⁺/T⁻ over impacting samples.
    EnergyRatio,
    /// |ω⁺| (rad/s).
    OmegaAfterNorm,
    /// |v⁺| (m/s).
    VelocityAfterNorm,
    /// Per touching plane, λ (N·s).
    Impulse,
    /// Per touching plane, −v_n⁺/v_n⁻.
    Rebound,
}

impl Statistic {
    /// Every statistic, in [`STATISTIC_NAMES`] order.
    pub const ALL: [Self; 5] = [
        Self::EnergyRatio,
        Self::OmegaAfterNorm,
        Self::VelocityAfterNorm,
        Self::Impulse,
        Self::Rebound,
    ];

    pub fn name(self) -> &'static str {
        STATISTIC_NAMES[self as usize]
    }
}

/// The statistics `[statistics] quantiles` may name.
pub const STATISTIC_NAMES: [&str; 5] = [
    "energy_ratio",
    "omega_after_norm",
    "velocity_after_norm",
    "impulse",
    "rebound",
];

/// Which statistics keep quantiles (a histogram each). Serialised as the
/// list of their names, in [`Statistic::ALL`] order (as `[statistics]
/// quantiles` is written).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Quantiles([bool; 5]);

impl Quantiles {
    pub const NONE: Self = Self([false; 5]);
    pub const ALL: Self = Self([true; 5]);

    pub fn has(self, s: Statistic) -> bool {
        self.0[s as usize]
    }

    fn insert(&mut self, s: Statistic) {
        self.0[s as usize] = true;
    }

    /// The statistics kept, in [`Statistic::ALL`] order.
    pub fn iter(self) -> impl Iterator<Item = Statistic> {
        Statistic::ALL.into_iter().filter(move |&s| self.has(s))
    }
}

impl serde::Serialize for Quantiles {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(self.iter().map(Statistic::name))
    }
}

/// The statistics a run keeps beyond counts and moments: those not
/// requested are not computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct Statistics {
    pub quantiles: Quantiles,
    /// Moments and histograms per active contact set.
    pub by_active_set: bool,
}

impl Statistics {
    /// Everything: what `--all-effects` computes.
    pub const ALL: Self = Self {
        quantiles: Quantiles::ALL,
        by_active_set: true,
    };

    fn from_raw(raw: Option<&crate::config::RawStatistics>) -> Result<Self, Bad> {
        // Default: the energy ratio's (means and CIs for the others); each
        // histogram costs about one memory increment per sample
        // (docs/performance.md).
        let mut quantiles = Quantiles::NONE;
        quantiles.insert(Statistic::EnergyRatio);
        if let Some(names) = raw.and_then(|r| r.quantiles.as_ref()) {
            quantiles = Quantiles::NONE;
            for (i, n) in names.iter().enumerate() {
                match Statistic::ALL.into_iter().find(|s| s.name() == n) {
                    Some(k) if quantiles.has(k) => {
                        return Err(bad(
                            &["statistics", &format!("quantiles[{i}]")],
                            format!("{n:?} is listed twice"),
                        ))
                    }
                    Some(k) => quantiles.insert(k),
                    None => {
                        return Err(bad(
                            &["statistics", &format!("quantiles[{i}]")],
                            format!(
                                "unknown statistic {n:?} (expected one of {})",
                                STATISTIC_NAMES.join(", ")
                            ),
                        ))
                    }
                }
            }
        }
        Ok(Self {
            quantiles,
            by_active_set: raw.and_then(|r| r.by_active_set).unwrap_or(false),
        })
    }

    /// `quantiles of energy_ratio, …; by active set` for the effects line.
    pub fn describe(&self) -> String {
        let q: Vec<&str> = self.quantiles.iter().map(Statistic::name).collect();
        let q = if q.is_empty() {
            "no quantiles".to_string()
        } else {
            format!("quantiles of {}", q.join(", "))
        };
        if self.by_active_set {
            format!("{q}; moments per active set")
        } else {
            q
        }
    }
}

impl Effects {
    pub(super) fn derive(
        raw: &RawScene,
        body: &Ellipsoid,
        planes: &[NamedPlane],
        touching: &[usize],
        drop: bool,
        (tolerance, tight): (f64, f64),
    ) -> Result<Self, Bad> {
        let e = raw.effects.clone().unwrap_or_default();
        let flight = e.flight.unwrap_or(drop);
        if flight && !drop {
            return Err(bad(
                &["effects", "flight"],
                "flight = true needs placement.drop (a touching placement starts at contact)",
            ));
        }
        if !flight && drop {
            return Err(bad(
                &["effects", "flight"],
                "flight = false contradicts placement.drop",
            ));
        }
        let positive = |path: &[&str], v: Option<f64>, default: f64| -> Result<f64, Bad> {
            let x = v.unwrap_or(default);
            if x.is_finite() && x > 0.0 {
                Ok(x)
            } else {
                Err(bad(path, format!("must be a finite number > 0, got {x}")))
            }
        };
        let gravity = match e.gravity {
            Some(g) if !(g.is_finite() && g >= 0.0) => {
                return Err(bad(
                    &["effects", "gravity"],
                    format!("must be a finite number ≥ 0 (m/s²), got {g}"),
                ))
            }
            Some(g) => g,
            None if flight => 9.81,
            None => 0.0,
        };
        if !flight && (e.gravity.is_some() || e.bounces.is_some() || e.settle.is_some()) {
            return Err(bad(
                &["effects"],
                "gravity, bounces and settle need flight (placement.drop)",
            ));
        }
        let bounces = e.bounces.unwrap_or(1);
        if bounces == 0 || bounces > 10_000 {
            return Err(bad(
                &["effects", "bounces"],
                format!("must be in 1..=10000, got {bounces}"),
            ));
        }
        let energy_floor = match e.energy_floor {
            Some(f) if !(f.is_finite() && (0.0..1.0).contains(&f)) => {
                return Err(bad(
                    &["effects", "energy_floor"],
                    format!("must be in [0, 1), got {f}"),
                ))
            }
            Some(f) => f,
            None => 1e-4,
        };
        let rk4 = match e.flight_rotation.as_deref() {
            None | Some("exact") => false,
            Some("rk4") => true,
            Some(other) => {
                return Err(bad(
                    &["effects", "flight_rotation"],
                    format!("must be \"exact\" or \"rk4\", got {other:?}"),
                ))
            }
        };
        if !flight && e.flight_rotation.is_some() {
            return Err(bad(
                &["effects", "flight_rotation"],
                "flight_rotation needs flight (placement.drop)",
            ));
        }
        if !rk4 && e.flight_step.is_some() {
            return Err(bad(
                &["effects", "flight_step"],
                "flight_step is the RK4 step: it needs flight_rotation = \"rk4\" (the default, \"exact\", has no step)",
            ));
        }
        let flight_step = positive(&["effects", "flight_step"], e.flight_step, 1e-3)?;
        // The search stops at contact: a tight length of the scene's own
        // (`tight`, what the contact tolerance is by default), never above
        // the contact tolerance, which only says which planes join an impact.
        let toi_tolerance = positive(
            &["effects", "toi_tolerance"],
            e.toi_tolerance,
            tight.min(tolerance.max(1e-12)),
        )?;
        if toi_tolerance > tolerance.max(1e-12) {
            return Err(bad(
                &["effects", "toi_tolerance"],
                format!(
                    "must not exceed contact_tolerance ({tolerance:e} m), got {toi_tolerance:e}"
                ),
            ));
        }
        let horizon = positive(&["effects", "horizon"], e.horizon, 10.0)?;
        let s = body.semi_axes();
        let sphere = body.is_sphere();
        let orthogonal = touching.iter().enumerate().all(|(a, &i)| {
            touching[a + 1..]
                .iter()
                .all(|&j| planes[i].plane.normal().dot(planes[j].plane.normal()) == 0.0)
        });
        let coupled = if flight {
            // Which planes meet at an impact is decided in flight.
            planes.len() > 1 && !(sphere && orthogonal_all(planes))
        } else {
            touching.len() > 1 && !(sphere && orthogonal)
        };
        let friction = if flight {
            planes.iter().any(|p| p.plane.friction() > 0.0)
        } else {
            touching.iter().any(|&i| planes[i].plane.friction() > 0.0)
        };
        Ok(Self {
            rotational_coupling: !sphere,
            coupled_contacts: coupled,
            friction,
            flight,
            gravity,
            bounces,
            energy_floor,
            settle: e.settle.unwrap_or(true),
            flight_step,
            toi_tolerance,
            horizon,
            flight_rotation: if !flight {
                "none"
            } else if s.x == s.y {
                "precession"
            } else if rk4 {
                "rk4"
            } else {
                "elliptic"
            },
            per_sample: raw.output.as_ref().is_some_and(|o| o.per_sample),
            statistics: Statistics::from_raw(raw.statistics.as_ref())?,
            constant_spin: match (sphere, &raw.angular_velocity) {
                (true, RawVector::Fixed { value }) => Some(DVec3::from_array(*value).length()),
                _ => None,
            },
        })
    }

    /// One line for the terminal.
    pub fn line(&self) -> String {
        let mut on = Vec::new();
        let mut off = Vec::new();
        for (name, x) in [
            ("rotational coupling", self.rotational_coupling),
            ("coupled contacts (LCP)", self.coupled_contacts),
            ("friction", self.friction),
            ("flight", self.flight),
            ("per-sample rows", self.per_sample),
        ] {
            if x {
                on.push(name)
            } else {
                off.push(name)
            }
        }
        let mut s = format!("effects: on [{}]; off [{}]", on.join(", "), off.join(", "));
        if let Some(w) = self.constant_spin {
            s.push_str(&format!("; |ω⁺| = {w} in every sample (not computed)"));
        }
        if self.flight {
            // Drop studies keep their own per-bounce statistics.
            s.push_str(&format!(
                "; gravity {} m/s², up to {} bounce(s), rotation in flight: {}",
                self.gravity, self.bounces, self.flight_rotation
            ));
        } else {
            s.push_str(&format!("; statistics: {}", self.statistics.describe()));
        }
        s
    }
}

fn orthogonal_all(planes: &[NamedPlane]) -> bool {
    planes.iter().enumerate().all(|(a, p)| {
        planes[a + 1..]
            .iter()
            .all(|q| p.plane.normal().dot(q.plane.normal()) == 0.0)
    })
}
/// Effects to keep computing although the scene does not need them (same
/// answers, more work): for measuring what compiling an effect out saves.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Keep {
    /// Lever arms, per-lane G, ω⁺ and the orientation draws.
    pub rotation: bool,
    /// The LCP over the touching planes.
    pub lcp: bool,
    /// Every statistic: all quantiles and the per-set groups.
    pub statistics: bool,
    /// The frictional kernel, also where every μ is zero (it then gives
    /// the frictionless laws' answers; the friction statistics stay off).
    /// Not part of `all`: the frictional kernel solves `newton` with
    /// several contacts by Gauss–Seidel, to its stopping rule rather than
    /// exactly.
    pub friction: bool,
}

impl Keep {
    pub const NONE: Self = Self {
        rotation: false,
        lcp: false,
        statistics: false,
        friction: false,
    };
    /// Every frictionless effect (rotation, the LCP, every statistic).
    pub const ALL: Self = Self {
        rotation: true,
        lcp: true,
        statistics: true,
        friction: false,
    };

    /// Both sets of effects.
    pub fn union(self, o: Self) -> Self {
        Self {
            rotation: self.rotation || o.rotation,
            lcp: self.lcp || o.lcp,
            statistics: self.statistics || o.statistics,
            friction: self.friction || o.friction,
        }
    }
}

impl std::str::FromStr for Keep {
    type Err = String;

    /// Parses one effect: `rotation`, `lcp`, `statistics`, `friction` or
    /// `all` (every frictionless effect).
    fn from_str(name: &str) -> Result<Self, String> {
        let mut k = Self::NONE;
        match name {
            "rotation" => k.rotation = true,
            "lcp" => k.lcp = true,
            "statistics" => k.statistics = true,
            "friction" => k.friction = true,
            "all" => k = Self::ALL,
            other => {
                return Err(format!(
                    "unknown effect {other:?} (expected rotation, lcp, statistics, friction or all)"
                ))
            }
        }
        Ok(k)
    }
}
