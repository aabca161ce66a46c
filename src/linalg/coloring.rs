//! Column grouping for sparse Jacobians by differences or closed-form products: columns that
//! share no row go in one group, so one residual evaluation (or one Jacobian–vector product)
//! gives all their entries (Curtis, Powell & Reid, IMA J. Appl. Math. 13, 1974; greedy
//! distance-2 colouring, Gebremedhin, Manne & Pothen, SIAM Rev. 47, 2005).

/// A sparsity pattern's columns grouped so that no two columns of a group share a row
/// (greedy distance-2 coloring), with the pattern's entries listed group by group.
#[derive(Debug, Clone)]
pub(crate) struct ColumnGroups {
    /// Columns of group `c`: `cols[col_ptr[c]..col_ptr[c + 1]]`.
    pub(crate) cols: Vec<usize>,
    pub(crate) col_ptr: Vec<usize>,
    /// Entries `(row, col)` of group `c`: `entries[entry_ptr[c]..entry_ptr[c + 1]]`.
    pub(crate) entries: Vec<(usize, usize)>,
    pub(crate) entry_ptr: Vec<usize>,
}

impl ColumnGroups {
    /// Groups the columns of a `k × k` pattern (duplicates allowed, positions `< k`).
    pub(crate) fn new(k: usize, pattern: &[(usize, usize)]) -> Self {
        let mut entries: Vec<(usize, usize)> = pattern.to_vec();
        entries.sort_unstable_by_key(|&(r, c)| (c, r));
        entries.dedup();
        let mut rows_of_col = vec![Vec::new(); k];
        let mut cols_of_row = vec![Vec::new(); k];
        for &(r, c) in &entries {
            rows_of_col[c].push(r);
            cols_of_row[r].push(c);
        }
        let mut color = vec![usize::MAX; k];
        let mut forbidden: Vec<usize> = Vec::new(); // forbidden[c] == j: color c taken near j
        let mut ncolors = 0;
        for j in 0..k {
            for &r in &rows_of_col[j] {
                for &c2 in &cols_of_row[r] {
                    let col = color[c2];
                    if col != usize::MAX {
                        forbidden[col] = j;
                    }
                }
            }
            let c = (0..ncolors)
                .find(|&c| forbidden[c] != j)
                .unwrap_or_else(|| {
                    forbidden.push(usize::MAX);
                    ncolors += 1;
                    ncolors - 1
                });
            color[j] = c;
        }
        let mut col_ptr = vec![0; ncolors + 1];
        let mut entry_ptr = vec![0; ncolors + 1];
        for j in 0..k {
            col_ptr[color[j] + 1] += 1;
        }
        for &(_, c) in &entries {
            entry_ptr[color[c] + 1] += 1;
        }
        for c in 0..ncolors {
            col_ptr[c + 1] += col_ptr[c];
            entry_ptr[c + 1] += entry_ptr[c];
        }
        let mut cols = vec![0; k];
        let mut fill = col_ptr.clone();
        for j in 0..k {
            cols[fill[color[j]]] = j;
            fill[color[j]] += 1;
        }
        let mut grouped = vec![(0, 0); entries.len()];
        let mut fill = entry_ptr.clone();
        for &(r, c) in &entries {
            grouped[fill[color[c]]] = (r, c);
            fill[color[c]] += 1;
        }
        Self {
            cols,
            col_ptr,
            entries: grouped,
            entry_ptr,
        }
    }

    pub(crate) fn groups(&self) -> usize {
        self.col_ptr.len() - 1
    }
}
