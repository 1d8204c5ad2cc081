//! A validated plane with the name the scene gave it.

use crate::physics::Plane;

/// A plane with its scene name.
#[derive(Debug, Clone, PartialEq)]
pub struct NamedPlane {
    pub name: String,
    pub plane: Plane,
}
