//! Members over MPI ranks (feature `mpi`, on rsmpi): rank `r` of `n` runs the members whose
//! position in the list is `r mod n`, and the rows travel to rank 0 as JSON (serde_json writes
//! every `f64` in its shortest round-trip form and reads it back exactly), where they are sorted
//! by id and written as a one-process run writes them — byte for byte. Without the feature a
//! single "rank" runs everything and nothing MPI is compiled.

use lieflow::scene::sweep::MemberRow;

/// The MPI environment (finalized when dropped) and this process's rank and size.
pub struct Ranks {
    #[cfg(feature = "mpi")]
    universe: Option<mpi::environment::Universe>,
    /// This process's rank.
    pub rank: usize,
    /// The number of ranks.
    pub size: usize,
}

impl Ranks {
    /// Initializes MPI (a process started without `mpirun` is a world of one).
    #[cfg(feature = "mpi")]
    pub fn init() -> Self {
        use mpi::traits::Communicator;
        let universe = mpi::initialize();
        let (rank, size) = universe.as_ref().map_or((0, 1), |u| {
            let w = u.world();
            (w.rank() as usize, w.size() as usize)
        });
        Self {
            universe,
            rank,
            size,
        }
    }

    /// One process.
    #[cfg(not(feature = "mpi"))]
    pub fn init() -> Self {
        Self { rank: 0, size: 1 }
    }

    /// Gathers every rank's rows to rank 0: `Some(all rows)` there, `None` elsewhere.
    #[cfg(feature = "mpi")]
    pub fn gather(
        &self,
        rows: Vec<(MemberRow, f64)>,
    ) -> Result<Option<Vec<(MemberRow, f64)>>, String> {
        use mpi::datatype::PartitionMut;
        use mpi::traits::{Communicator, Root};
        let Some(universe) = &self.universe else {
            return Ok(Some(rows));
        };
        if self.size == 1 {
            return Ok(Some(rows));
        }
        let world = universe.world();
        let root = world.process_at_rank(0);
        let mine = serde_json::to_vec(&rows).map_err(|e| e.to_string())?;
        let count = i32::try_from(mine.len())
            .map_err(|_| "rows too large for one MPI message".to_owned())?;
        if self.rank != 0 {
            root.gather_into(&count);
            root.gather_varcount_into(&mine[..]);
            return Ok(None);
        }
        let mut counts = vec![0i32; self.size];
        root.gather_into_root(&count, &mut counts[..]);
        let displs: Vec<i32> = counts
            .iter()
            .scan(0i32, |acc, &c| {
                let d = *acc;
                *acc += c;
                Some(d)
            })
            .collect();
        let mut buf = vec![0u8; counts.iter().map(|&c| c as usize).sum()];
        {
            let mut part = PartitionMut::new(&mut buf[..], counts.clone(), &displs[..]);
            root.gather_varcount_into_root(&mine[..], &mut part);
        }
        let mut all = Vec::new();
        for (d, c) in displs.iter().zip(&counts) {
            let chunk = &buf[*d as usize..(*d + *c) as usize];
            let rows: Vec<(MemberRow, f64)> =
                serde_json::from_slice(chunk).map_err(|e| e.to_string())?;
            all.extend(rows);
        }
        all.sort_by_key(|(r, _)| r.id);
        Ok(Some(all))
    }

    /// One process: the rows as they are.
    #[cfg(not(feature = "mpi"))]
    pub fn gather(
        &self,
        rows: Vec<(MemberRow, f64)>,
    ) -> Result<Option<Vec<(MemberRow, f64)>>, String> {
        Ok(Some(rows))
    }
}
