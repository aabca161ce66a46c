//! The evaluation counter of a scene's term (and its clock when profiling).

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// Evaluation counter of one term (and its time when profiling). Atomic so that a model can be
/// shared between the flows that use it; each run is single-threaded, so a count is a plain
/// load and store (no locked read-modify-write on the hot path: a `fetch_add` costs ~20 cycles,
/// more than a small term's evaluation).
#[derive(Debug, Default)]
pub(crate) struct Counter {
    evaluations: AtomicU64,
    nanos: AtomicU64,
}

impl Counter {
    #[inline]
    pub(crate) fn hit(&self) {
        let n = self.evaluations.load(Ordering::Relaxed);
        self.evaluations.store(n + 1, Ordering::Relaxed);
    }
    pub(crate) fn add_time(&self, since: Instant) {
        let ns = since.elapsed().as_nanos() as u64;
        let total = self.nanos.load(Ordering::Relaxed);
        self.nanos.store(total + ns, Ordering::Relaxed);
    }
    pub(crate) fn evaluations(&self) -> u64 {
        self.evaluations.load(Ordering::Relaxed)
    }
    pub(crate) fn nanos(&self) -> u64 {
        self.nanos.load(Ordering::Relaxed)
    }
    pub(crate) fn reset(&self) {
        self.evaluations.store(0, Ordering::Relaxed);
        self.nanos.store(0, Ordering::Relaxed);
    }
}
