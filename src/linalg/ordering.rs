//! Bandwidth-reducing orderings of sparsity patterns: the reverse Cuthill–McKee ordering, which
//! renumbers the unknowns of a pattern whose graph is long and thin (a chain of bodies with its
//! constraints, in the order "all positions, then all multipliers") so that every entry lies in
//! a narrow band, where [`BandedLu`](super::BandedLu) factors it without fill beyond the band.
//!
//! References: Cuthill & McKee, *Reducing the bandwidth of sparse symmetric matrices*, Proc.
//! 24th ACM National Conference (1969); George & Liu, *Computer Solution of Large Sparse
//! Positive Definite Systems*, Prentice-Hall 1981, §4.3 (the reversal, and the pseudo-peripheral
//! starting node, Gibbs–Poole–Stockmeyer style).

/// The reverse Cuthill–McKee ordering of the graph of `pattern` (symmetrized, `k` nodes):
/// `order[new] = old`. Each connected component is numbered by a breadth-first search from a
/// pseudo-peripheral node, neighbours by increasing degree, and the whole numbering reversed.
pub(crate) fn reverse_cuthill_mckee(k: usize, pattern: &[(usize, usize)]) -> Vec<usize> {
    let mut adjacent: Vec<Vec<usize>> = vec![Vec::new(); k];
    for &(r, c) in pattern {
        if r != c && r < k && c < k {
            adjacent[r].push(c);
            adjacent[c].push(r);
        }
    }
    for a in &mut adjacent {
        a.sort_unstable();
        a.dedup();
    }
    let degree: Vec<usize> = adjacent.iter().map(Vec::len).collect();
    for a in &mut adjacent {
        a.sort_by_key(|&v| degree[v]);
    }
    // Seeds by increasing degree: each component starts from its least connected node.
    let mut seeds: Vec<usize> = (0..k).collect();
    seeds.sort_by_key(|&v| degree[v]);
    let mut order = Vec::with_capacity(k);
    let mut numbered = vec![false; k];
    let mut level = vec![usize::MAX; k];
    for seed in seeds {
        if numbered[seed] {
            continue;
        }
        let start = pseudo_peripheral(seed, &adjacent, &degree, &mut level);
        let first = order.len();
        order.push(start);
        numbered[start] = true;
        let mut head = first;
        while head < order.len() {
            let v = order[head];
            head += 1;
            for &u in &adjacent[v] {
                if !numbered[u] {
                    numbered[u] = true;
                    order.push(u);
                }
            }
        }
    }
    order.reverse();
    order
}

/// A node of large eccentricity in `seed`'s component: breadth-first searches from the last
/// level's least connected node while the number of levels grows (George & Liu, §4.3.2).
/// `level`: scratch of `k` entries.
fn pseudo_peripheral(
    seed: usize,
    adjacent: &[Vec<usize>],
    degree: &[usize],
    level: &mut [usize],
) -> usize {
    let mut start = seed;
    let mut depth = 0;
    let mut queue = Vec::new();
    // A handful of sweeps suffices in practice; the bound keeps a pathological graph linear.
    for _ in 0..8 {
        queue.clear();
        queue.push(start);
        level[start] = 0;
        let mut head = 0;
        while head < queue.len() {
            let v = queue[head];
            head += 1;
            for &u in &adjacent[v] {
                if level[u] == usize::MAX {
                    level[u] = level[v] + 1;
                    queue.push(u);
                }
            }
        }
        let last = level[*queue.last().unwrap_or(&start)];
        let candidate = queue
            .iter()
            .copied()
            .filter(|&v| level[v] == last)
            .min_by_key(|&v| degree[v])
            .unwrap_or(start);
        for &v in &queue {
            level[v] = usize::MAX;
        }
        if last <= depth && depth > 0 {
            break;
        }
        depth = last;
        start = candidate;
    }
    start
}

/// The band of `pattern` renumbered by `place` (`place[old] = new`): `(lower, upper)`.
pub(crate) fn bandwidth_under(pattern: &[(usize, usize)], place: &[usize]) -> (usize, usize) {
    pattern.iter().fold((0, 0), |(lo, up), &(r, c)| {
        let (r, c) = (place[r], place[c]);
        (lo.max(r.saturating_sub(c)), up.max(c.saturating_sub(r)))
    })
}

/// `place[old] = new` from `order[new] = old`.
pub(crate) fn inverse(order: &[usize]) -> Vec<usize> {
    let mut place = vec![0; order.len()];
    for (new, &old) in order.iter().enumerate() {
        place[old] = new;
    }
    place
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A chain's reduced system in the order "positions, then multipliers": `n` bodies of one
    /// coordinate, rod `a` between bodies `a − 1` and `a` (body −1 the anchor).
    fn chain_kkt(n: usize) -> Vec<(usize, usize)> {
        let mut p: Vec<(usize, usize)> = (0..2 * n).map(|i| (i, i)).collect();
        for a in 0..n {
            for b in [a.wrapping_sub(1), a] {
                if b < n {
                    p.push((n + a, b));
                    p.push((b, n + a));
                }
            }
        }
        p
    }

    #[test]
    fn a_chain_in_block_order_becomes_a_narrow_band() {
        let n = 200;
        let pattern = chain_kkt(n);
        let natural = bandwidth_under(&pattern, &(0..2 * n).collect::<Vec<_>>());
        assert!(
            natural.0 >= n,
            "the natural order spans the blocks: {natural:?}"
        );
        let order = reverse_cuthill_mckee(2 * n, &pattern);
        let mut sorted = order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..2 * n).collect::<Vec<_>>(), "a permutation");
        let band = bandwidth_under(&pattern, &inverse(&order));
        // Interleaved body, rod, body, …: every entry within two places of the diagonal.
        assert!(band.0 <= 2 && band.1 <= 2, "{band:?}");
    }

    #[test]
    fn disconnected_and_empty_patterns_are_permutations() {
        let pattern = [(0, 0), (2, 3), (3, 2), (5, 5)];
        let order = reverse_cuthill_mckee(6, &pattern);
        let mut sorted = order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..6).collect::<Vec<_>>());
        assert!(reverse_cuthill_mckee(0, &[]).is_empty());
    }
}
