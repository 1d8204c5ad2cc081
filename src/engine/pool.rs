//! Values shared by the workers of a run.

/// Values shared by the workers of a run (scratch spaces, cleared batch
/// accumulators): taken for a batch and given back, so a run allocates
/// about as many as it uses at once, not one per batch.
pub(crate) struct Pool<W> {
    free: std::sync::Mutex<Vec<W>>,
}

impl<W> Pool<W> {
    pub(crate) fn new() -> Self {
        Self {
            free: std::sync::Mutex::new(Vec::new()),
        }
    }
    pub(crate) fn take(&self, make: impl FnOnce() -> W) -> W {
        let popped = self.free.lock().expect("pool").pop();
        popped.unwrap_or_else(make)
    }
    pub(crate) fn give(&self, w: W) {
        self.free.lock().expect("pool").push(w);
    }
}
