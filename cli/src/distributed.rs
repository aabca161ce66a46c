//! Members over MPI ranks (feature `mpi`, on rsmpi): rank `r` of `n` runs the members whose
//! position in the list is `r mod n`, and the rows travel to rank 0 as JSON with every `f64` as
//! its bit pattern (so NaN, ±∞ and every last bit survive), where they are sorted by id and
//! written as a one-process run writes them — byte for byte. Without the feature a single
//! "rank" runs everything and nothing MPI is compiled.

use lieflow_lab::sweep::MemberRow;

/// A row on the wire: every `f64` as `to_bits`.
#[cfg(feature = "mpi")]
#[derive(serde::Serialize, serde::Deserialize)]
struct Wire {
    id: usize,
    parameters: Vec<(String, u64)>,
    t: u64,
    steps: usize,
    opt: [Option<u64>; 6],
    final_state_max_abs: u64,
    error: Option<(String, String)>,
    seconds: u64,
}

#[cfg(feature = "mpi")]
impl Wire {
    fn from_row((r, seconds): &(MemberRow, f64)) -> Self {
        let b = |v: Option<f64>| v.map(f64::to_bits);
        Self {
            id: r.id,
            parameters: r
                .parameters
                .iter()
                .map(|(p, v)| (p.clone(), v.to_bits()))
                .collect(),
            t: r.t.to_bits(),
            steps: r.steps,
            opt: [
                b(r.max_abs_g),
                b(r.energy_initial),
                b(r.energy_final),
                b(r.max_abs_energy_error),
                b(r.dissipated),
                None,
            ],
            final_state_max_abs: r.final_state_max_abs.to_bits(),
            error: r.error.clone(),
            seconds: seconds.to_bits(),
        }
    }
    fn into_row(self) -> (MemberRow, f64) {
        let f = |v: Option<u64>| v.map(f64::from_bits);
        (
            MemberRow {
                id: self.id,
                parameters: self
                    .parameters
                    .into_iter()
                    .map(|(p, v)| (p, f64::from_bits(v)))
                    .collect(),
                t: f64::from_bits(self.t),
                steps: self.steps,
                max_abs_g: f(self.opt[0]),
                energy_initial: f(self.opt[1]),
                energy_final: f(self.opt[2]),
                max_abs_energy_error: f(self.opt[3]),
                dissipated: f(self.opt[4]),
                final_state_max_abs: f64::from_bits(self.final_state_max_abs),
                error: self.error,
            },
            f64::from_bits(self.seconds),
        )
    }
}

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
        let wire: Vec<Wire> = rows.iter().map(Wire::from_row).collect();
        let mine = serde_json::to_vec(&wire).map_err(|e| e.to_string())?;
        let count = i32::try_from(mine.len())
            .map_err(|_| "rows too large for one MPI message".to_owned())?;
        if self.rank != 0 {
            root.gather_into(&count);
            root.gather_varcount_into(&mine[..]);
            return Ok(None);
        }
        let mut counts = vec![0i32; self.size];
        root.gather_into_root(&count, &mut counts[..]);
        let mut displs = Vec::with_capacity(self.size);
        let mut total = 0i32;
        for &c in &counts {
            displs.push(total);
            total = total.checked_add(c).ok_or_else(|| {
                "the rows of all ranks exceed 2 GiB: slice the sweep with --members".to_owned()
            })?;
        }
        let mut buf = vec![0u8; counts.iter().map(|&c| c as usize).sum()];
        {
            let mut part = PartitionMut::new(&mut buf[..], counts.clone(), &displs[..]);
            root.gather_varcount_into_root(&mine[..], &mut part);
        }
        let mut all = Vec::new();
        for (d, c) in displs.iter().zip(&counts) {
            let chunk = &buf[*d as usize..(*d + *c) as usize];
            let rows: Vec<Wire> = serde_json::from_slice(chunk).map_err(|e| e.to_string())?;
            all.extend(rows.into_iter().map(Wire::into_row));
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
