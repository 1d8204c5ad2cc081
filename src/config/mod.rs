//! Configuration: scene files as parsed (raw, serde), validated into a
//! [`Scene`] in one place, with the effects it calls for, its sweep grid,
//! and single-impact cases for `impactmc solve`.

mod bad;
pub mod case;
mod effects;
pub mod path;
mod plane;
pub mod raw;
mod scene;
pub mod sweep;
mod validate;

pub use crate::physics::MAX_DROP_PLANES;
pub use effects::{Effects, Keep, Quantiles, Statistic, Statistics, STATISTIC_NAMES};
pub use plane::NamedPlane;
pub use raw::*;
pub use scene::{
    load_scene, Contact, DropBox, OrientationDist, Overrides, Placement, Precision, Sampling,
    Scene, SceneError, SceneText, Target, VectorDist, DEFAULT_TOLERANCE_RELATIVE, MAX_LOG2_POINTS,
    MAX_SAMPLES,
};
pub use validate::parse_law;
