//! The time basis of the Petrov–Galerkin step on `[0, 1]`: Lagrange polynomials of degree
//! `k − 1` at the `k` Gauss points (the trial space of `x'`, `z`, `λ` and the test space), and
//! an `s`-point Gauss rule for the integrals.

/// Gauss–Legendre nodes and weights on `[0, 1]` with `s` points (exact for degree `2s − 1`):
/// Newton on the Legendre polynomial `P_s` from Tricomi's initial guesses, to round-off
/// (Golub & Welsch give the same nodes; this is the textbook route of Press et al., §4.6).
pub(super) fn gauss(s: usize) -> (Vec<f64>, Vec<f64>) {
    let mut nodes = vec![0.0; s];
    let mut weights = vec![0.0; s];
    for i in 0..s {
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (s as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            // P_s(x) and P_s'(x) by the three-term recurrence.
            let (mut p0, mut p1) = (1.0, x);
            for j in 2..=s {
                let p2 = ((2 * j - 1) as f64 * x * p1 - (j - 1) as f64 * p0) / j as f64;
                p0 = p1;
                p1 = p2;
            }
            // P_s' = s (x P_s − P_{s−1}) / (x² − 1).
            dp = s as f64 * (x * p1 - p0) / (x * x - 1.0);
            let dx = p1 / dp;
            x -= dx;
            if dx.abs() <= 1e-16 {
                break;
            }
        }
        // Map [−1, 1] → [0, 1].
        nodes[s - 1 - i] = 0.5 * (1.0 + x);
        weights[s - 1 - i] = 1.0 / ((1.0 - x * x) * dp * dp);
    }
    (nodes, weights)
}

/// The basis: `k` Gauss points `c_j` with weights `β_j` (the Lagrange basis `ℓ_j` at them), and
/// an `s`-point rule `(e_r, b_r)`, with the tables a step needs.
#[derive(Debug, Clone)]
pub(super) struct Basis {
    /// `k`.
    pub(super) k: usize,
    /// `s`.
    pub(super) s: usize,
    /// `β_j = ∫₀¹ ℓ_j`: also `x_{n+1} = x_n + h Σ_j β_j x'(c_j)`.
    pub(super) beta: Vec<f64>,
    /// `e_r`, the quadrature nodes on `[0, 1]`.
    pub(super) e: Vec<f64>,
    /// `b_r`, the quadrature weights.
    pub(super) b: Vec<f64>,
    /// `ℓ_j(e_r)`, row-major `[r][j]`.
    pub(super) ell: Vec<f64>,
    /// `∫₀^{e_r} ℓ_j`, row-major `[r][j]`: `x(e_r) = x_n + h Σ_j A_rj x'(c_j)`.
    pub(super) a: Vec<f64>,
}

impl Basis {
    pub(super) fn new(k: usize, s: usize) -> Self {
        let (c, beta) = gauss(k);
        let (e, b) = gauss(s);
        // Coefficients of ℓ_j in the monomials: ℓ_j(τ) = Π_{i≠j} (τ − c_i)/(c_j − c_i).
        let coefficients: Vec<Vec<f64>> = (0..k)
            .map(|j| {
                let mut poly = vec![1.0];
                for (i, &ci) in c.iter().enumerate() {
                    if i == j {
                        continue;
                    }
                    let d = c[j] - ci;
                    let mut next = vec![0.0; poly.len() + 1];
                    for (p, &v) in poly.iter().enumerate() {
                        next[p + 1] += v / d;
                        next[p] -= v * ci / d;
                    }
                    poly = next;
                }
                poly
            })
            .collect();
        let eval = |poly: &[f64], t: f64| poly.iter().rev().fold(0.0, |acc, &v| acc * t + v);
        let integral = |poly: &[f64], t: f64| {
            poly.iter()
                .enumerate()
                .map(|(p, &v)| v * t.powi(p as i32 + 1) / (p + 1) as f64)
                .sum::<f64>()
        };
        let mut ell = vec![0.0; s * k];
        let mut a = vec![0.0; s * k];
        for r in 0..s {
            for j in 0..k {
                ell[r * k + j] = eval(&coefficients[j], e[r]);
                a[r * k + j] = integral(&coefficients[j], e[r]);
            }
        }
        Self {
            k,
            s,
            beta,
            e,
            b,
            ell,
            a,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_rules_integrate_to_their_degree() {
        for s in 1..=8 {
            let (x, w) = gauss(s);
            for d in 0..2 * s {
                let q: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(d as i32)).sum();
                let exact = 1.0 / (d as f64 + 1.0);
                assert!(
                    (q - exact).abs() < 1e-14,
                    "s = {s}, degree {d}: {q} vs {exact}"
                );
            }
        }
    }

    #[test]
    fn the_lagrange_tables_reproduce_polynomials() {
        let basis = Basis::new(3, 5);
        // ℓ_j sum to one, their integrals to the Gauss weights (which sum to one).
        for r in 0..basis.s {
            let sum: f64 = (0..3).map(|j| basis.ell[r * 3 + j]).sum();
            assert!((sum - 1.0).abs() < 1e-14);
            let int: f64 = (0..3).map(|j| basis.a[r * 3 + j]).sum();
            let (e, _) = gauss(5);
            assert!((int - e[r]).abs() < 1e-14);
        }
        assert!((basis.beta.iter().sum::<f64>() - 1.0).abs() < 1e-15);
    }
}
