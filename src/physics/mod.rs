//! Pure f64 reference of `docs/spec/physics.md`.
//!
//! Nothing in here draws random numbers, spawns threads or writes files: it is
//! the scalar model that every fast path of the engine is tested against.
//! Units are SI throughout (m, kg, s, rad).

mod body;
mod compliant;
mod contact;
mod elliptic;
mod flight;
pub mod friction;
mod laws;
mod lcp;
mod linalg;
mod plane;
mod rotation;
mod torque_free;

pub use body::{BodyError, Ellipsoid, Pose, State};
pub use compliant::{
    damping_for_restitution, damping_table, restitution_for_damping, solve_compliant,
    solve_compliant_with, CompliantError, CompliantOutcome, CompliantParams,
};
pub use contact::{inverse_inertance, kinetic_energy, support_point_lagrange, ContactGeometry};
pub(crate) use elliptic::THETA_TERMS;
pub use elliptic::{carlson_rf, carlson_rf_series, carlson_rj, Jacobi, ThetaPhase};
pub use flight::{
    advance, contact_near, precess, short_turn, sphere_clearance, spin_bound, time_of_impact,
    Carried, Impact, Motion, Rotation, CONTACT_STEPS,
};
pub use laws::{
    apply_impulses, solve_impact, ContactOutcome, Flags, ImpactError, ImpactOutcome, Law,
    DEGENERATE_EIGEN_THRESHOLD, ENERGY_GAIN_RELATIVE,
};
pub use lcp::{solve_lcp, LcpSolution, ACCEPT_RELATIVE, FEASIBILITY_RELATIVE, MAX_LCP_CONTACTS};
pub use linalg::{smallest_eigenvalue_scaled, SymMatrix};
pub use plane::{Plane, PlaneError, MAX_DROP_PLANES};
pub use rotation::{
    bryan_from_matrix, matrix_from_bryan, matrix_from_quaternion, quaternion_from_matrix, Bryan,
};
pub use torque_free::SEPARATRIX;
pub use torque_free::{rk4_rotation, TorqueFree};
