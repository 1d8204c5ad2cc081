//! A field error of a scene before its file and line are known: the
//! validation steps return it, [`Scene::validate`](super::Scene::validate)
//! adds where.

/// A field error before the file and line are known.
pub(super) struct Bad {
    pub(super) path: Vec<String>,
    pub(super) message: String,
}

pub(super) fn bad(path: &[&str], message: impl Into<String>) -> Bad {
    Bad {
        path: path.iter().map(|s| s.to_string()).collect(),
        message: message.into(),
    }
}
