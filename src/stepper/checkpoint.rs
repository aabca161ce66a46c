//! Checkpoints: everything a continuation depends on, so that a run restored from one equals
//! the run that went on from it, bit for bit.

use super::Stepper;
use crate::flow::{Flow, Ledger};
use crate::vector::Vector;
use std::borrow::BorrowMut;

/// A saved stepper: state, time grid, ledger and the flow's memory (warm starts of the
/// multipliers, held input values; see [`Flow::save_memory`]). Plain data: `Clone`, and
/// restorable into the stepper it came from or any stepper built the same way.
#[derive(Debug, Clone, PartialEq)]
pub struct Checkpoint<V: Vector> {
    x: V,
    last: V,
    last_ledger: Ledger<V::Real>,
    ledger: Ledger<V::Real>,
    t_base: V::Real,
    k_base: usize,
    h: V::Real,
    k: usize,
    memory: Vec<V::Real>,
}

impl<V: Vector> Checkpoint<V> {
    /// The saved state.
    pub fn state(&self) -> &V {
        &self.x
    }
    /// The saved time.
    pub fn time(&self) -> V::Real {
        self.t_base + <V::Real as crate::Real>::lit((self.k - self.k_base) as f64) * self.h
    }
    /// The number of values in the flow's memory.
    pub fn memory_len(&self) -> usize {
        self.memory.len()
    }
}

/// A checkpoint that does not fit the stepper it is restored into.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum CheckpointError {
    /// The saved state has another length.
    #[error("the checkpoint's state has {saved} components, the stepper's {expected}")]
    StateLength {
        /// Components in the checkpoint.
        saved: usize,
        /// Components in the stepper's state.
        expected: usize,
    },
    /// The saved flow memory has another length (another flow, or another model size).
    #[error(
        "the checkpoint's flow memory has {saved} values, this flow keeps {expected}: it was saved from another scheme or model"
    )]
    Memory {
        /// Values in the checkpoint.
        saved: usize,
        /// Values this flow saves.
        expected: usize,
    },
}

impl<V, F, S> Stepper<V, F, S>
where
    V: Vector,
    F: Flow<V>,
    S: BorrowMut<V>,
{
    /// Saves everything the continuation depends on. Kept Newton matrices cannot be saved:
    /// the flow forgets them here, so the run that goes on from this point and every run
    /// restored from the checkpoint rebuild them alike (a run that saved may therefore differ
    /// from one that never did, within the Newton tolerance). Allocates the checkpoint.
    pub fn save(&mut self) -> Checkpoint<V> {
        let mut memory = Vec::new();
        self.flow.save_memory(&mut memory);
        self.flow.restore_memory(&mut memory.as_slice());
        Checkpoint {
            x: self.x.borrow().clone(),
            last: self.last.clone(),
            last_ledger: self.last_ledger,
            ledger: self.ledger,
            t_base: self.t_base,
            k_base: self.k_base,
            h: self.h,
            k: self.k,
            memory,
        }
    }

    /// Restores a checkpoint: the following steps equal, bit for bit, those of the run that
    /// went on after [`save`](Self::save).
    ///
    /// # Errors
    /// [`CheckpointError`] when the checkpoint does not fit this stepper; nothing is changed.
    pub fn restore(&mut self, checkpoint: &Checkpoint<V>) -> Result<(), CheckpointError> {
        let expected = self.x.borrow().len();
        if checkpoint.x.len() != expected {
            return Err(CheckpointError::StateLength {
                saved: checkpoint.x.len(),
                expected,
            });
        }
        self.memory.clear();
        self.flow.save_memory(&mut self.memory);
        if self.memory.len() != checkpoint.memory.len() {
            return Err(CheckpointError::Memory {
                saved: checkpoint.memory.len(),
                expected: self.memory.len(),
            });
        }
        self.flow.restore_memory(&mut checkpoint.memory.as_slice());
        self.x.borrow_mut().copy_from(&checkpoint.x);
        self.last.copy_from(&checkpoint.last);
        self.last_ledger = checkpoint.last_ledger;
        self.ledger = checkpoint.ledger;
        self.t_base = checkpoint.t_base;
        self.k_base = checkpoint.k_base;
        self.h = checkpoint.h;
        self.k = checkpoint.k;
        Ok(())
    }
}
