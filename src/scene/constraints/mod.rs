//! The constraints a scene may declare, one file each: its table in the scene file (the serde
//! struct), its checks and the terms it declares, and each term's rows of `g(q) = 0` — the
//! residual, the products with `G(q)` and `G(q)ᵀ`, the gradient per body and the Hessian form.
//!
//! **Adding a constraint** is one new file here and one line in the `constraints!` list below:
//! the file's spec implements [`Declare`] (its terms, from the scene's bodies). A new kind of
//! term is a line in the `terms!` list too, and implements [`ConstraintOps`] (the rows, generic
//! in the scalar) and [`ConstraintInfo`] (its scales and forces in `f64`, for the compiler's
//! checks and the outputs); the joints between rigid bodies share one term, [`Rows`] (rows of
//! degree ≤ 2 built by `crate::rigid::joints`), and `joint.rs` (their ends, anchors and
//! axes). The model (`scene/model/constraints.rs`) runs the terms' rows in one loop,
//! dispatched statically.
//!
//! Positions are `q ∈ R^{dN}`, body `b` at `q[b·d .. b·d + d]`; every row's gradient with
//! respect to a body is a `d`-vector, given padded to three.

// Per-coordinate loops `for k in 0..d` index several arrays at once (q, v, a 3-vector).
#![allow(clippy::needless_range_loop)]

mod ball;
mod hinge;
pub(crate) mod joint;
mod pin;
mod plane;
mod rod;
mod rows;
mod slider;
mod sphere;
mod universal;
mod weld;

pub use ball::BallSpec;
pub use hinge::HingeSpec;
pub use pin::PinSpec;
pub use plane::PlaneSpec;
pub(crate) use rod::Rod;
pub use rod::RodSpec;
pub(crate) use rows::Rows;
pub use slider::SliderSpec;
pub(crate) use sphere::Sphere;
pub use sphere::SphereSpec;
pub use universal::UniversalSpec;
pub use weld::WeldSpec;

use crate::real::Real;
use crate::scene::bodies::Bodies;
use crate::scene::error::FieldPath;
use crate::scene::validate::Result;
use serde::Deserialize;

/// A constraint term as declared: its rows, its label, where it is in the file.
pub(crate) type Declared = (Constraint<f64>, String, FieldPath);

/// What a constraint file provides for its table in the scene file (whose struct also has the
/// label in messages, `name: Option<String>`, read by the `constraints!` list).
pub(crate) trait Declare {
    /// Checks the declaration against the bodies and appends its terms, labelled
    /// `constraints[i] <kind> <bodies>`, to `out`.
    fn declare(
        &self,
        i: usize,
        path: &FieldPath,
        bodies: &Bodies,
        out: &mut Vec<Declared>,
    ) -> Result<()>;
}

/// The rows of one constraint term on positions `q` (length `d N`). Row offsets are relative
/// to the term's first row; `out` and `mu` are the term's own rows.
pub(crate) trait ConstraintOps<T: Real> {
    /// Number of rows.
    fn rows(&self, d: usize) -> usize;
    /// `out = g(q)`.
    fn residual(&self, q: &[T], d: usize, out: &mut [T]);
    /// Calls `f(row, G_row(q) · v)` for each row, with body `b`'s part of `v` scaled by
    /// `scale[b]` when given (`W⁻¹ p` for the hidden constraint).
    fn row_dots(&self, q: &[T], v: &[T], d: usize, scale: Option<&[T]>, f: impl FnMut(usize, T));
    /// `out += α G(q)ᵀ μ`.
    fn gradient_transpose_add(&self, q: &[T], mu: &[T], alpha: T, d: usize, out: &mut [T]);
    /// Calls `f(row, body, ∂g_row/∂q_body)` for every body a row touches, in a fixed order
    /// (the sparsity pattern of `G` is read from it).
    fn gradients(&self, q: &[T], d: usize, f: impl FnMut(usize, usize, [T; 3]));
    /// Calls `f(row, column, ∂g_row/∂q_column)` for the entries of `G` the term can make
    /// non-zero, in a fixed order: by default every component of every body
    /// [`gradients`](Self::gradients) names; a term that knows its columns lists only those
    /// (a joint's rows touch some components of a slot).
    fn entries(&self, q: &[T], d: usize, mut f: impl FnMut(usize, usize, T)) {
        self.gradients(q, d, |row, body, g| {
            for (k, &gk) in g.iter().enumerate().take(d) {
                f(row, body * d + k, gk);
            }
        });
    }
    /// `out_row = uᵀ ∇²g_row v` (every scene constraint is at most quadratic: the Hessian is
    /// constant).
    fn hessian_form(&self, u: &[T], v: &[T], d: usize, out: &mut [T]);
    /// A length the constraint holds (a rod's, a sphere's radius), for the projection's
    /// residual tolerance; `None` for an affine row.
    fn length(&self) -> Option<T> {
        None
    }
    /// `out_row += vᵀ ∇²g_row v`, the term of `d²g/dt²` that does not depend on the
    /// acceleration.
    /// Every kind writes it in closed form (no scratch: it runs once per step in the peers'
    /// right-hand sides).
    fn velocity_curvature_add(&self, v: &[T], d: usize, out: &mut [T]);
}

/// What the compiler and the outputs read from a term, in `f64`.
pub(crate) trait ConstraintInfo {
    /// The kind's name in summaries and CSV columns (`"rod"`).
    fn kind(&self) -> &'static str;
    /// The bodies in its multipliers' CSV column (`a-b`, or one body).
    fn bodies(&self, name: &dyn Fn(usize) -> String) -> String;
    /// Per row, the size `ρ` of the terms its residual rounds and its length `ℓ` (the factor
    /// between a velocity and its hidden-constraint residual).
    fn scales(&self, q: &[f64], d: usize, out: &mut [(f64, f64)]);
    /// The force of a row per unit multiplier at `q` (the sign of the `constraint-force`
    /// output: the force on a body is `−G_qᵀλ`).
    fn force_per_multiplier(&self, q: &[f64], d: usize) -> f64;
    /// The suffix of row `r`'s CSV column in a term of several rows (`"0"`, `"1"`, …).
    fn row_name(&self, r: usize) -> String {
        r.to_string()
    }
}

/// Declares the constraints: the `type`s of `[[constraints]]` tables ([`ConstraintSpec`]) and
/// the dispatch to their files.
macro_rules! constraints {
    ($( $(#[doc = $doc:literal])* $Variant:ident($module:ident::$Spec:ident) = $name:literal, )+) => {
        /// A holonomic constraint, by `type`.
        #[derive(Debug, Clone, PartialEq, Deserialize)]
        #[serde(tag = "type")]
        pub enum ConstraintSpec {
            $( $(#[doc = $doc])* #[serde(rename = $name)] $Variant($module::$Spec), )+
        }

        impl ConstraintSpec {
            /// Its `name`, if the file gives one.
            pub fn name(&self) -> Option<&String> {
                match self {
                    $( Self::$Variant(s) => s.name.as_ref(), )+
                }
            }
            /// Checks it and appends its terms.
            pub(crate) fn declare(
                &self,
                i: usize,
                path: &FieldPath,
                bodies: &Bodies,
                out: &mut Vec<Declared>,
            ) -> Result<()> {
                match self {
                    $( Self::$Variant(s) => s.declare(i, path, bodies, out), )+
                }
            }
        }

    };
}

/// Declares the kinds of constraint terms ([`Constraint`]) and dispatches their rows to their
/// files.
macro_rules! terms {
    ($( $(#[doc = $doc:literal])* $Variant:ident($module:ident::$Term:ident), )+) => {
        /// A constraint term's rows.
        #[derive(Debug, Clone, PartialEq)]
        pub(crate) enum Constraint<T = f64> {
            $( $(#[doc = $doc])* $Variant($module::$Term<T>), )+
        }

        impl<T: Real> Constraint<T> {
            /// See [`ConstraintOps::rows`].
            #[inline(always)]
            pub(crate) fn rows(&self, d: usize) -> usize {
                match self {
                    $( Self::$Variant(c) => c.rows(d), )+
                }
            }
            /// See [`ConstraintOps::residual`].
            #[inline(always)]
            pub(crate) fn residual(&self, q: &[T], d: usize, out: &mut [T]) {
                match self {
                    $( Self::$Variant(c) => c.residual(q, d, out), )+
                }
            }
            /// See [`ConstraintOps::row_dots`].
            #[inline(always)]
            pub(crate) fn row_dots(
                &self,
                q: &[T],
                v: &[T],
                d: usize,
                scale: Option<&[T]>,
                f: impl FnMut(usize, T),
            ) {
                match self {
                    $( Self::$Variant(c) => c.row_dots(q, v, d, scale, f), )+
                }
            }
            /// See [`ConstraintOps::gradient_transpose_add`].
            #[inline(always)]
            pub(crate) fn gradient_transpose_add(
                &self,
                q: &[T],
                mu: &[T],
                alpha: T,
                d: usize,
                out: &mut [T],
            ) {
                match self {
                    $( Self::$Variant(c) => c.gradient_transpose_add(q, mu, alpha, d, out), )+
                }
            }
            /// See [`ConstraintOps::gradients`].
            #[inline(always)]
            pub(crate) fn gradients(&self, q: &[T], d: usize, f: impl FnMut(usize, usize, [T; 3])) {
                match self {
                    $( Self::$Variant(c) => c.gradients(q, d, f), )+
                }
            }
            /// See [`ConstraintOps::entries`].
            #[inline(always)]
            pub(crate) fn entries(&self, q: &[T], d: usize, f: impl FnMut(usize, usize, T)) {
                match self {
                    $( Self::$Variant(c) => c.entries(q, d, f), )+
                }
            }
            /// See [`ConstraintOps::hessian_form`].
            #[inline(always)]
            pub(crate) fn hessian_form(&self, u: &[T], v: &[T], d: usize, out: &mut [T]) {
                match self {
                    $( Self::$Variant(c) => c.hessian_form(u, v, d, out), )+
                }
            }
            /// See [`ConstraintOps::length`].
            pub(crate) fn length(&self) -> Option<T> {
                match self {
                    $( Self::$Variant(c) => c.length(), )+
                }
            }
            /// See [`ConstraintOps::velocity_curvature_add`].
            #[inline(always)]
            pub(crate) fn velocity_curvature_add(&self, v: &[T], d: usize, out: &mut [T]) {
                match self {
                    $( Self::$Variant(c) => c.velocity_curvature_add(v, d, out), )+
                }
            }
        }

        impl Constraint<f64> {
            /// The same term in the scalar `U` (every parameter rounded to `U`).
            pub(crate) fn with_scalar<U: Real>(&self) -> Constraint<U> {
                match self {
                    $( Self::$Variant(c) => Constraint::$Variant(c.with_scalar()), )+
                }
            }
            /// Its [`ConstraintInfo`].
            pub(crate) fn info(&self) -> &dyn ConstraintInfo {
                match self {
                    $( Self::$Variant(c) => c, )+
                }
            }
        }
    };
}

constraints! {
    /// `q_b = point` for each body `b` (`dim` rows each).
    Pin(pin::PinSpec) = "pin",
    /// `|q_a − q_b| = length`, or `|q_a − point| = length`.
    Rod(rod::RodSpec) = "rod",
    /// `|q_b − center| = radius` for each body `b`.
    Sphere(sphere::SphereSpec) = "sphere",
    /// `n · q_b = offset` for each body `b`.
    Plane(plane::PlaneSpec) = "plane",
    /// A ball joint between bodies (3D): their anchors coincide.
    Ball(ball::BallSpec) = "ball",
    /// A hinge between bodies (3D): a ball joint about a common axis.
    Hinge(hinge::HingeSpec) = "hinge",
    /// A universal joint between bodies (3D): a ball joint with a cross.
    Universal(universal::UniversalSpec) = "universal",
    /// A slider between bodies (3D): relative motion along one axis only.
    Slider(slider::SliderSpec) = "slider",
    /// Two bodies fixed to one another, merged into one rigid body when the scene is compiled.
    Weld(weld::WeldSpec) = "weld",
}

terms! {
    /// `q_b − point = 0` (`d` rows).
    Pin(pin::Pin),
    /// `(|q_a − r|² − L²)/2 = 0` with `r = q_b` or a fixed point.
    Rod(rod::Rod),
    /// `(|q_b − c|² − r²)/2 = 0`.
    Sphere(sphere::Sphere),
    /// `n · q_b − offset = 0`, `|n| = 1`.
    Plane(plane::Plane),
    /// Rows of degree ≤ 2 on slots: a rigid body's `QᵀQ = I`, a joint.
    Rows(rows::Rows),
}

/// Body `b`'s `d` components of `q` (stride `d`), zero-padded to three, built from values
/// rather than written per coordinate into a stack array: a dot product that loads such an
/// array as one vector stalls on store forwarding.
#[inline(always)]
pub(crate) fn at3<T: Real>(q: &[T], b: usize, d: usize) -> [T; 3] {
    let i = b * d;
    if d == 3 {
        [q[i], q[i + 1], q[i + 2]]
    } else {
        [q[i], q[i + 1], T::lit(0.0)]
    }
}

/// [`at3`] times `scale[b]` if given.
#[inline(always)]
pub(crate) fn scaled3<T: Real>(v: &[T], b: usize, d: usize, scale: Option<&[T]>) -> [T; 3] {
    let x = at3(v, b, d);
    match scale {
        Some(w) => [w[b] * x[0], w[b] * x[1], w[b] * x[2]],
        None => x,
    }
}

/// `q_a − q_b`, or `q_a − point` without `b`.
#[inline(always)]
pub(crate) fn difference3<T: Real>(
    q: &[T],
    a: usize,
    b: Option<usize>,
    point: &[T; 3],
    d: usize,
) -> [T; 3] {
    let at = |k: usize| {
        q[a * d + k]
            - match b {
                Some(b) => q[b * d + k],
                None => point[k],
            }
    };
    if d == 3 {
        [at(0), at(1), at(2)]
    } else {
        [at(0), at(1), T::lit(0.0)]
    }
}

/// `out_b += s u` on body `b`'s `d` components (stride `d`).
#[inline(always)]
pub(crate) fn add3<T: Real>(out: &mut [T], b: usize, d: usize, s: T, u: [T; 3]) {
    let i = b * d;
    out[i] = out[i] + s * u[0];
    out[i + 1] = out[i + 1] + s * u[1];
    if d == 3 {
        out[i + 2] = out[i + 2] + s * u[2];
    }
}

/// `a · b`.
#[inline(always)]
pub(crate) fn dot3<T: Real>(a: [T; 3], b: [T; 3]) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `a − b`.
#[inline(always)]
pub(crate) fn sub3<T: Real>(a: [T; 3], b: [T; 3]) -> [T; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// The largest of body `b`'s coordinates in absolute value.
pub(crate) fn extent(q: &[f64], b: usize, d: usize) -> f64 {
    (0..d).fold(0.0f64, |a, k| a.max(q[b * d + k].abs()))
}

/// The largest entry of `p` in absolute value.
pub(crate) fn size3(p: &[f64; 3]) -> f64 {
    p.iter().fold(0.0f64, |a, x| a.max(x.abs()))
}
