//! A rigid body's solid as a drawing shows it ([`Shape`], part of a [`Sketch`]): kept with the
//! body when its inertia is declared as a shape, or the inertia box of its moments.
//!
//! [`Sketch`]: crate::scene::sketch::Sketch

/// A rigid body's solid, in its body frame, for drawing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// A box with these sides along the body's axes.
    Box {
        /// Its three sides.
        size: [f64; 3],
    },
    /// A cylinder along the body's third axis.
    Cylinder {
        /// Its radius.
        radius: f64,
        /// Its height.
        height: f64,
    },
    /// A ball.
    Sphere {
        /// Its radius.
        radius: f64,
    },
    /// The uniform box of the body's mass and principal moments, its sides along the principal
    /// axes (the columns of `Q`, not of `R`): side `i` is `√(12 Eᵢ/m)` with
    /// `Eᵢ = (J_j + J_k − J_i)/2` the director's mass. Drawn for bodies given by moments or a
    /// tensor, and for welded bodies.
    InertiaBox {
        /// Its three sides.
        size: [f64; 3],
    },
}
