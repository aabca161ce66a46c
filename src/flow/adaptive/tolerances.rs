//! What accuracy a user asks for: relative and absolute tolerances, scalars or one per
//! component, and the weighted norm an adaptive flow measures its error estimate in.

use crate::error::SetupError;
use crate::real::Real;

/// `rtol` and `atol`, each one scalar or one value per state component. An error estimate
/// `e` of a step from `x₀` to `x₁` is measured as the weighted root mean square
///
/// ```text
/// ‖e‖ = sqrt( (1/n) Σᵢ ( eᵢ / (atolᵢ + rtolᵢ max(|x₀ᵢ|, |x₁ᵢ|)) )² ),
/// ```
///
/// and a step is accepted when `‖e‖ ≤ 1` (Hairer, Nørsett & Wanner, *Solving ODEs I*, §II.4,
/// (4.11); the norm of DOP853, ODEX, SUNDIALS and DifferentialEquations.jl).
#[derive(Debug, Clone, PartialEq)]
pub struct Tolerances<T> {
    rtol: Vec<T>,
    atol: Vec<T>,
}

impl<T: Real> Tolerances<T> {
    /// The same `rtol` and `atol` for every component.
    ///
    /// # Errors
    /// [`SetupError::InvalidParameter`] for a tolerance that is negative or not finite, or
    /// both zero.
    pub fn new(rtol: T, atol: T) -> Result<Self, SetupError> {
        Self::per_component(vec![rtol], vec![atol])
    }

    /// One `rtol` and one `atol` per component (or one value for all: a vector of length 1).
    ///
    /// # Errors
    /// As [`new`](Self::new), for every pair.
    pub fn per_component(rtol: Vec<T>, atol: Vec<T>) -> Result<Self, SetupError> {
        if rtol.is_empty() || atol.is_empty() {
            return Err(SetupError::InvalidParameter {
                name: "tolerances".to_owned(),
                value: f64::NAN,
                requirement: "at least one rtol and one atol",
            });
        }
        let n = rtol.len().max(atol.len());
        for i in 0..n {
            let (r, a) = (pick(&rtol, i), pick(&atol, i));
            let ok = |v: T| v >= T::zero() && v.is_finite();
            if !(ok(r) && ok(a)) || (r == T::zero() && a == T::zero()) {
                return Err(SetupError::InvalidParameter {
                    name: format!("tolerance of component {i} (rtol, atol)"),
                    value: if ok(r) {
                        a.to_f64_lossy()
                    } else {
                        r.to_f64_lossy()
                    },
                    requirement: "non-negative and finite, not both zero",
                });
            }
        }
        Ok(Self { rtol, atol })
    }

    /// The relative tolerance of component `i`.
    pub fn rtol(&self, i: usize) -> T {
        pick(&self.rtol, i)
    }

    /// The absolute tolerance of component `i`.
    pub fn atol(&self, i: usize) -> T {
        pick(&self.atol, i)
    }

    /// The smallest relative tolerance (it sets the starting order).
    pub fn tightest_rtol(&self) -> T {
        self.rtol.iter().copied().fold(T::infinity(), T::min)
    }

    /// How many components the tolerances name (1: the same for every component).
    pub fn components(&self) -> usize {
        self.rtol.len().max(self.atol.len())
    }

    /// Whether the tolerances fit a state of `n` components (scalars fit every length).
    pub fn fits(&self, n: usize) -> bool {
        [self.rtol.len(), self.atol.len()]
            .iter()
            .all(|&l| l == 1 || l == n)
    }

    /// `‖a − b‖` in the weighted norm, the weights from `x0` and `x1`.
    pub fn error(&self, a: &[T], b: &[T], x0: &[T], x1: &[T]) -> T {
        Self::rms(a.len(), |i| {
            (a[i] - b[i]) / self.weight(i, x0[i].abs().max(x1[i].abs()))
        })
    }

    /// `‖a‖` in the weighted norm, the weights from `x0` and `x1`.
    pub fn norm(&self, a: &[T], x0: &[T], x1: &[T]) -> T {
        Self::rms(a.len(), |i| {
            a[i] / self.weight(i, x0[i].abs().max(x1[i].abs()))
        })
    }

    /// `√(Σ eᵢ² / n)` of the `n` weighted components `e(i)` (0 for none).
    #[inline(always)]
    fn rms(n: usize, e: impl Fn(usize) -> T) -> T {
        if n == 0 {
            return T::zero();
        }
        let mut sum = T::zero();
        for i in 0..n {
            let v = e(i);
            sum = sum + v * v;
        }
        (sum / T::lit(n as f64)).sqrt()
    }

    /// `atolᵢ + rtolᵢ · size`: component `i`'s weight at magnitude `size`.
    fn weight(&self, i: usize, size: T) -> T {
        self.atol(i) + self.rtol(i) * size
    }

    /// `ε ‖max(|x₀|, |x₁|)‖`, the state's own round-off in the weighted norm: what two
    /// computations of the same step may differ by when each is exact to rounding. At most
    /// `ε / min rtol`.
    pub fn roundoff(&self, x0: &[T], x1: &[T]) -> T {
        T::epsilon()
            * Self::rms(x0.len(), |i| {
                let size = x0[i].abs().max(x1[i].abs());
                size / self.weight(i, size)
            })
    }
}

fn pick<T: Copy>(v: &[T], i: usize) -> T {
    if v.len() == 1 { v[0] } else { v[i] }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_norm_is_the_weighted_root_mean_square() {
        let t = Tolerances::<f64>::new(1e-3, 1e-6).unwrap();
        // Components 1 and 0: scales 1e-3·2 + 1e-6 and 1e-6.
        let e = t.error(
            &[2.0 + 2.001e-3, 1e-6],
            &[2.0, 0.0],
            &[2.0, 0.0],
            &[1.0, 0.0],
        );
        assert!((e - 1.0).abs() < 1e-12, "{e}");
        let per = Tolerances::per_component(vec![0.0, 1e-3], vec![1e-8, 0.0]).unwrap();
        assert_eq!((per.rtol(0), per.atol(0), per.rtol(1)), (0.0, 1e-8, 1e-3));
        assert!(per.fits(2) && !per.fits(3) && t.fits(7));
    }

    #[test]
    fn the_round_off_is_epsilon_times_the_state_in_the_weighted_norm() {
        let t = Tolerances::<f64>::new(1e-12, 1e-12).unwrap();
        // |x| = 1 and 0: weights 2e-12 and 1e-12, sizes 1 and 0.
        let r = t.roundoff(&[1.0, 0.0], &[-0.5, 0.0]);
        let want = f64::EPSILON * (0.5 * (1.0 / 2e-12f64).powi(2)).sqrt();
        assert!((r - want).abs() <= 1e-12 * want, "{r} {want}");
        // At most ε / rtol, whatever the size.
        assert!(t.roundoff(&[1e30], &[1e30]) <= f64::EPSILON / 1e-12);
        assert_eq!(t.roundoff(&[], &[]), 0.0);
    }

    #[test]
    fn meaningless_tolerances_are_refused() {
        assert!(Tolerances::new(-1e-6, 1e-6).is_err());
        assert!(Tolerances::new(0.0, 0.0).is_err());
        assert!(Tolerances::new(f64::NAN, 1e-6).is_err());
        assert!(Tolerances::<f64>::per_component(vec![], vec![1.0]).is_err());
    }
}
