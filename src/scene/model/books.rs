//! Whether a scene's flows keep the energy books of its damping: a switch shared by the flows
//! and the run that reads (or does not read) the books.

use std::sync::atomic::{AtomicBool, Ordering};

/// Whether the flows of a scene book the energy their damping removes (the [`Ledger`]'s
/// `dissipated`, [`Simulation::dissipated`]). On by default. A run that reads no books turns
/// it off ([`Simulation::read_books`]); the flows then skip the work the books cost beyond the
/// motion — on damped bodies under constraints the account on the motion the constraints allow
/// (`consistent.rs`: a projection of the momenta per free flight, a sixth of the base step of
/// ten damped particles on a sphere), and the dashpots' account on the consistent momentum
/// (`dashpot.rs`) — and book nothing. The motion is the same to the bit either way: the books
/// are an account of it, not a part of it.
///
/// Atomic only so that the model can be shared (`Arc`) between the flows and the run; each run
/// is single-threaded and reads it with a relaxed load (no ordering is needed: it is changed
/// between steps, never during one).
///
/// [`Ledger`]: crate::flow::Ledger
/// [`Simulation::dissipated`]: crate::scene::Simulation::dissipated
/// [`Simulation::read_books`]: crate::scene::Simulation::read_books
#[derive(Debug)]
pub(crate) struct Books(AtomicBool);

impl Default for Books {
    fn default() -> Self {
        Self(AtomicBool::new(true))
    }
}

impl Books {
    /// Whether the flows book the damping's energy.
    #[inline]
    pub(crate) fn on(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }

    /// Turns the books on or off.
    pub(crate) fn set(&self, on: bool) {
        self.0.store(on, Ordering::Relaxed);
    }
}
