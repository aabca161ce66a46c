//! The potential `V(q)`, the sum of the scene's potential terms: its value, gradient, Hessian
//! product, and its exact flow, the kick `p ← p − t ∇V(q)`.

use super::{SceneModel, terms::Potential};
use crate::real::Real;

#[inline]
pub(super) fn distance<T: Real>(q: &[T], d: usize, a: usize, b: usize) -> T {
    let mut s = T::lit(0.0);
    for k in 0..d {
        let z = q[a * d + k] - q[b * d + k];
        s = s + (z * z);
    }
    s.sqrt()
}

impl<T: Real> SceneModel<T> {
    /// `V(q)`, the sum of the potential terms.
    pub(crate) fn potential_energy(&self, q: &[T]) -> T {
        let d = self.dim;
        let mut v = T::lit(0.0);
        for term in &self.potentials {
            v = v + self.timed(&term.counter, || match &term.potential {
                Potential::Gravity { forces } => {
                    let mut e = T::lit(0.0);
                    for (b, f) in forces {
                        for k in 0..d {
                            e = e - (f[k] * q[b * d + k]);
                        }
                    }
                    e
                }
                Potential::Pairs { pairs, law } => {
                    let mut e = T::lit(0.0);
                    for &(a, b) in pairs {
                        e = e + (law.eval(distance(q, d, a, b)).0);
                    }
                    e
                }
                Potential::Trap {
                    stiffness,
                    center,
                    bodies,
                } => {
                    let mut e = T::lit(0.0);
                    for &b in bodies {
                        for k in 0..d {
                            let z = q[b * d + k] - center[k];
                            e = e + (z * z);
                        }
                    }
                    T::lit(0.5) * *stiffness * e
                }
            });
        }
        v
    }

    /// `out += α ∇V(q)`, `V` the sum of the potential terms (length `d N`: positions only).
    pub fn potential_gradient_add(&self, q: &[T], alpha: T, out: &mut [T]) {
        let d = self.dim;
        for term in &self.potentials {
            self.timed(&term.counter, || match &term.potential {
                Potential::Gravity { forces } => {
                    for (b, f) in forces {
                        for k in 0..d {
                            out[b * d + k] = out[b * d + k] - (alpha * f[k]);
                        }
                    }
                }
                Potential::Pairs { pairs, law } => {
                    for &(a, b) in pairs {
                        let r = distance(q, d, a, b);
                        let s = alpha * law.eval(r).1;
                        for k in 0..d {
                            let z = s * (q[a * d + k] - q[b * d + k]);
                            out[a * d + k] = out[a * d + k] + (z);
                            out[b * d + k] = out[b * d + k] - (z);
                        }
                    }
                }
                Potential::Trap {
                    stiffness,
                    center,
                    bodies,
                } => {
                    for &b in bodies {
                        for k in 0..d {
                            out[b * d + k] =
                                out[b * d + k] + (alpha * *stiffness * (q[b * d + k] - center[k]));
                        }
                    }
                }
            });
        }
    }

    /// `out += ∇²V(q) v`.
    pub(super) fn potential_hessian_apply_add(&self, q: &[T], v: &[T], out: &mut [T]) {
        let d = self.dim;
        for term in &self.potentials {
            self.timed(&term.counter, || match &term.potential {
                Potential::Gravity { .. } => {}
                Potential::Pairs { pairs, law } => {
                    for &(a, b) in pairs {
                        let r = distance(q, d, a, b);
                        let (_, d1, d2) = law.eval(r);
                        // ∇²φ u = (φ'/r) u + (φ'' − φ'/r) (r̂·u) r̂, u = v_a − v_b.
                        let mut ru = T::lit(0.0);
                        for k in 0..d {
                            ru = ru
                                + ((q[a * d + k] - q[b * d + k]) * (v[a * d + k] - v[b * d + k]));
                        }
                        // A zero-length spring has d2 = d1: no radial term (and no 0/0 at r = 0).
                        let s = if d2 == d1 {
                            T::lit(0.0)
                        } else {
                            (d2 - d1) * ru / (r * r)
                        };
                        for k in 0..d {
                            let z = d1 * (v[a * d + k] - v[b * d + k])
                                + s * (q[a * d + k] - q[b * d + k]);
                            out[a * d + k] = out[a * d + k] + (z);
                            out[b * d + k] = out[b * d + k] - (z);
                        }
                    }
                }
                Potential::Trap {
                    stiffness, bodies, ..
                } => {
                    for &b in bodies {
                        for k in 0..d {
                            out[b * d + k] = out[b * d + k] + (*stiffness * v[b * d + k]);
                        }
                    }
                }
            });
        }
    }

    /// The kick `p ← p − t ∇V(q)`: the exact flow of all potential terms together. `scratch`
    /// holds `dN` entries.
    pub fn kick(&self, t: T, x: &mut [T], scratch: &mut [T]) {
        let nq = self.dim * self.masses.len();
        let (q, p) = x.split_at_mut(nq);
        scratch.fill(T::lit(0.0));
        self.potential_gradient_add(q, T::lit(1.0), scratch);
        for (pi, gi) in p.iter_mut().zip(scratch.iter()) {
            *pi = *pi - (t * *gi);
        }
    }
}
