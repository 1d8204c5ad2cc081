//! The four impact laws of physics.md ("Impact laws") over the touching
//! contacts, and the post-impact state they produce.

use glam::DVec3;

use super::friction;
use super::lcp::{solve_lcp, MAX_LCP_CONTACTS};
use super::{
    inverse_inertance, kinetic_energy, smallest_eigenvalue_scaled, ContactGeometry, Ellipsoid,
    Plane, Pose, State, SymMatrix,
};

/// `energy_gain` fires when `T⁺ > T⁻(1 + ENERGY_GAIN_RELATIVE)`.
pub const ENERGY_GAIN_RELATIVE: f64 = 1e-9;

/// `degenerate` fires when the smallest eigenvalue of the unit-diagonal
/// scaling of G over the touching contacts is below this.
pub const DEGENERATE_EIGEN_THRESHOLD: f64 = 1e-12;

/// An impact law (physics.md, laws 1–4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Law {
    /// Law 1, the paper's decoupled law (eq. 23 and 35):
    /// `λ_i = −(1 + k_i) v_n,i / G_ii` on each approaching contact.
    Paper,
    /// Law 2, Newton coupled (Moreau-type LCP): `λ ≥ 0`,
    /// `w = v_n⁺ + K min(v_n⁻, 0) ≥ 0`, `λ·w = 0` over touching contacts.
    Newton,
    /// Law 3, Poisson coupled: compression LCP, then expansion LCP.
    Poisson,
    /// Law 4, projected Gauss–Seidel on law 2: `sweeps` sweeps from λ = 0,
    /// contacts in index order.
    Pgs {
        /// Gauss–Seidel sweeps.
        sweeps: u32,
    },
    /// Energetic restitution (friction.md, law 4): Darboux–Keller
    /// integration in the normal impulse, one touching contact. Without
    /// friction it is `newton`.
    Stronge,
}

impl Law {
    /// The law's name as used in files and tables: `paper`, `newton`,
    /// `poisson`, `pgs8`.
    pub fn name(&self) -> String {
        match self {
            Law::Paper => "paper".into(),
            Law::Newton => "newton".into(),
            Law::Poisson => "poisson".into(),
            Law::Pgs { sweeps } => format!("pgs{sweeps}"),
            Law::Stronge => "stronge".into(),
        }
    }
}

/// Flags an impact can raise (defined in tests/data/golden/README.md).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Flags {
    /// `T⁺ > T⁻(1 + 1e-9)`.
    pub energy_gain: bool,
    /// G over the touching contacts is singular or nearly so.
    pub degenerate: bool,
    /// The Newton LCP had no solution; the plastic (k = 0) one was used.
    pub jammed: bool,
    /// No LCP candidate met the conditions even after the plastic fallback;
    /// the least-violating impulses were used (never expected for a
    /// physically consistent pose). With friction: a single-contact solve
    /// found no valid case, or a Darboux–Keller impact never ended.
    pub unsolved: bool,
    /// With friction: a single-contact solve had several valid solutions.
    pub ambiguous: bool,
    /// With friction: neither Newton's Gauss–Seidel nor its plastic
    /// re-solve converged; the frictionless `newton` result was used.
    pub unconverged: bool,
}

/// One plane's part of an impact.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactOutcome {
    pub geometry: ContactGeometry,
    /// `|distance| ≤ tolerance`.
    pub touching: bool,
    /// Touching and `v_n < 0`.
    pub approaching: bool,
    pub normal_velocity_before: f64,
    /// Impulse λ (N·s), zero for contacts not touching.
    pub impulse: f64,
    pub normal_velocity_after: f64,
    /// Tangential impulse `f = P − λn` (world, N·s); zero without friction.
    pub tangential_impulse: DVec3,
    /// `|c⁺_t|`, the contact point's tangential speed after (m/s).
    pub sliding_after: f64,
}

/// Outcome of one impact.
#[derive(Debug, Clone, PartialEq)]
pub struct ImpactOutcome {
    pub contacts: Vec<ContactOutcome>,
    /// Post-impact state.
    pub after: State,
    pub energy_before: f64,
    pub energy_after: f64,
    pub flags: Flags,
    /// Smallest eigenvalue of the unit-diagonal G over touching contacts (1
    /// with fewer than two).
    pub min_eigenvalue: f64,
}

/// Why an impact could not be solved.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ImpactError {
    #[error("{0} planes touch at once; the exact LCP solver handles at most {MAX_LCP_CONTACTS}")]
    TooManyContacts(usize),
    #[error("law stronge takes one touching plane; planes {0:?} touch at once")]
    StrongeSeveral(Vec<usize>),
    #[error("law poisson is not defined with friction; touching plane {plane} has friction {mu}")]
    PoissonFriction { plane: usize, mu: f64 },
}

/// `v⁺ = v + Σλ_i n_i/m`, `ω⁺ = ω + J⁻¹ Σλ_i ρ_i` (physics.md, "Contact
/// velocity and inertance").
pub fn apply_impulses(
    body: &Ellipsoid,
    state: State,
    normals: &[DVec3],
    levers: &[DVec3],
    lambda: &[f64],
) -> State {
    let mut linear = DVec3::ZERO;
    let mut angular = DVec3::ZERO;
    for ((n, r), &l) in normals.iter().zip(levers).zip(lambda) {
        linear += *n * l;
        angular += *r * l;
    }
    State {
        velocity: state.velocity + linear / body.mass(),
        omega: state.omega + angular / body.inertia(),
    }
}

/// Solves the impact of `body` at `pose` moving with `state` against
/// `planes` under `law`. Contacts with `|d| ≤ tolerance` (m) touch.
pub fn solve_impact(
    body: &Ellipsoid,
    pose: Pose,
    state: State,
    planes: &[Plane],
    law: Law,
    tolerance: f64,
) -> Result<ImpactOutcome, ImpactError> {
    let geometry: Vec<ContactGeometry> = planes
        .iter()
        .map(|p| ContactGeometry::new(body, pose.rotation, pose.centre, p))
        .collect();
    let vn: Vec<f64> = geometry
        .iter()
        .zip(planes)
        .map(|(g, p)| g.normal_velocity(p, state.velocity, state.omega))
        .collect();
    let touching: Vec<usize> = (0..planes.len())
        .filter(|&i| geometry[i].distance.abs() <= tolerance)
        .collect();
    if touching.len() > MAX_LCP_CONTACTS {
        return Err(ImpactError::TooManyContacts(touching.len()));
    }
    if law == Law::Stronge && touching.len() > 1 {
        return Err(ImpactError::StrongeSeveral(touching));
    }
    let rough = touching.iter().find(|&&i| planes[i].friction() > 0.0);
    if let (Law::Poisson, Some(&plane)) = (law, rough) {
        return Err(ImpactError::PoissonFriction {
            plane,
            mu: planes[plane].friction(),
        });
    }
    let normals: Vec<DVec3> = touching.iter().map(|&i| planes[i].normal()).collect();
    let levers: Vec<DVec3> = touching.iter().map(|&i| geometry[i].lever).collect();
    let k: Vec<f64> = touching.iter().map(|&i| planes[i].restitution()).collect();
    let v: Vec<f64> = touching.iter().map(|&i| vn[i]).collect();
    let g = inverse_inertance(body, &normals, &levers);

    let mut flags = Flags::default();
    let min_eigenvalue = smallest_eigenvalue_scaled(&g);
    flags.degenerate = min_eigenvalue < DEGENERATE_EIGEN_THRESHOLD;

    let mut tangential = vec![DVec3::ZERO; touching.len()];
    let (lambda, after) = if rough.is_some() {
        // Friction on a touching plane: the laws of friction.md.
        let ct = friction::Contacts::new(
            body,
            pose.rotation,
            state.velocity,
            state.omega,
            &touching
                .iter()
                .map(|&i| geometry[i].body_point)
                .collect::<Vec<_>>(),
            &normals,
            &touching
                .iter()
                .map(|&i| planes[i].friction())
                .collect::<Vec<_>>(),
            &k,
        );
        let mut s = match law {
            Law::Paper => friction::paper(&ct),
            Law::Newton => friction::newton(&ct),
            Law::Pgs { sweeps } => friction::pgs(&ct, sweeps),
            Law::Stronge => friction::stronge(&ct),
            Law::Poisson => unreachable!("poisson with friction is refused above"),
        };
        if s.unconverged {
            let mut ignored = Flags::default();
            let lambda = newton(&g, &v, &k, &mut ignored);
            s.impulses = normals.iter().zip(&lambda).map(|(n, l)| *n * *l).collect();
        }
        flags.ambiguous = s.ambiguous;
        flags.unsolved = s.unsolved;
        flags.jammed = s.jammed;
        flags.unconverged = s.unconverged;
        let mut linear = DVec3::ZERO;
        let mut angular = DVec3::ZERO;
        let mut lambda = Vec::with_capacity(touching.len());
        for (t, (&i, p)) in touching.iter().zip(&s.impulses).enumerate() {
            linear += *p;
            angular += geometry[i].body_point.cross(pose.rotation.transpose() * *p);
            let l = normals[t].dot(*p);
            lambda.push(l);
            tangential[t] = *p - normals[t] * l;
        }
        let after = State {
            velocity: state.velocity + linear / body.mass(),
            omega: state.omega + angular / body.inertia(),
        };
        (lambda, after)
    } else {
        let lambda = match law {
            Law::Paper => paper(&g, &v, &k),
            Law::Newton | Law::Stronge => newton(&g, &v, &k, &mut flags),
            Law::Poisson => poisson(&g, &v, &k, &mut flags),
            Law::Pgs { sweeps } => pgs(&g, &newton_q(&v, &k), sweeps),
        };
        let after = apply_impulses(body, state, &normals, &levers, &lambda);
        (lambda, after)
    };
    let energy_before = kinetic_energy(body, state.velocity, state.omega);
    let energy_after = kinetic_energy(body, after.velocity, after.omega);
    flags.energy_gain = energy_after > energy_before * (1.0 + ENERGY_GAIN_RELATIVE);

    let mut impulse = vec![0.0; planes.len()];
    let mut tangential_impulse = vec![DVec3::ZERO; planes.len()];
    for ((&i, &l), &f) in touching.iter().zip(&lambda).zip(&tangential) {
        impulse[i] = l;
        tangential_impulse[i] = f;
    }
    let contacts = (0..planes.len())
        .map(|i| {
            let is_touching = geometry[i].distance.abs() <= tolerance;
            ContactOutcome {
                geometry: geometry[i],
                touching: is_touching,
                approaching: is_touching && vn[i] < 0.0,
                normal_velocity_before: vn[i],
                impulse: impulse[i],
                normal_velocity_after: geometry[i].normal_velocity(
                    &planes[i],
                    after.velocity,
                    after.omega,
                ),
                tangential_impulse: tangential_impulse[i],
                sliding_after: {
                    let n = planes[i].normal();
                    let c =
                        after.velocity + pose.rotation * after.omega.cross(geometry[i].body_point);
                    (c - n * n.dot(c)).length()
                },
            }
        })
        .collect();
    Ok(ImpactOutcome {
        contacts,
        after,
        energy_before,
        energy_after,
        flags,
        min_eigenvalue,
    })
}

/// Law 1: each approaching contact on its own, `λ_i = −(1+k_i) v_n,i / G_ii`.
fn paper(g: &SymMatrix, v: &[f64], k: &[f64]) -> Vec<f64> {
    (0..v.len())
        .map(|i| {
            if v[i] < 0.0 {
                -(1.0 + k[i]) * v[i] / g.get(i, i)
            } else {
                0.0
            }
        })
        .collect()
}

/// `q_i = v_n,i + k_i min(v_n,i, 0)`, the Newton LCP's constant term.
fn newton_q(v: &[f64], k: &[f64]) -> Vec<f64> {
    v.iter().zip(k).map(|(&v, &k)| v + k * v.min(0.0)).collect()
}

/// Law 2. If no λ exists (a body jammed between touching parallel planes),
/// the same contacts are solved with k = 0 and the result flagged `jammed`.
fn newton(g: &SymMatrix, v: &[f64], k: &[f64], flags: &mut Flags) -> Vec<f64> {
    let sol = solve_lcp(g, &newton_q(v, k));
    if sol.feasible {
        return sol.lambda;
    }
    flags.jammed = true;
    let plastic = solve_lcp(g, v);
    flags.unsolved = !plastic.feasible;
    plastic.lambda
}

/// Law 3: compression `v_c = v_n + Gλc ≥ 0 ⊥ λc ≥ 0`, then expansion
/// `v_n⁺ = v_c + G(Kλc + μ) ≥ 0 ⊥ μ ≥ 0`; `λ = λc + Kλc + μ`.
fn poisson(g: &SymMatrix, v: &[f64], k: &[f64], flags: &mut Flags) -> Vec<f64> {
    let compression = solve_lcp(g, v);
    let lc = &compression.lambda;
    let klc: Vec<f64> = lc.iter().zip(k).map(|(l, k)| l * k).collect();
    let g_lc = g.mul_vec(lc);
    let g_klc = g.mul_vec(&klc);
    let q: Vec<f64> = (0..v.len()).map(|i| v[i] + g_lc[i] + g_klc[i]).collect();
    let expansion = solve_lcp(g, &q);
    flags.unsolved = !(compression.feasible && expansion.feasible);
    (0..v.len())
        .map(|i| lc[i] + klc[i] + expansion.lambda[i])
        .collect()
}

/// Law 4: projected Gauss–Seidel, `λ_i ← max(0, λ_i − w_i/G_ii)`.
fn pgs(g: &SymMatrix, q: &[f64], sweeps: u32) -> Vec<f64> {
    let n = q.len();
    let mut lambda = vec![0.0; n];
    for _ in 0..sweeps {
        for i in 0..n {
            let w: f64 = q[i] + (0..n).map(|j| g.get(i, j) * lambda[j]).sum::<f64>();
            lambda[i] = (lambda[i] - w / g.get(i, i)).max(0.0);
        }
    }
    lambda
}
