//! The scalar type used throughout lieflow.

use core::fmt::{Debug, Display};
use num_traits::{Float, FloatConst, FromPrimitive};

/// A real floating-point scalar (`f64`, `f32`, or any type with the same capabilities).
///
/// Core code is generic over `Real` only; backends (nalgebra, faer) add their own bounds
/// where they need them, so `x.abs()` is never ambiguous in generic code.
pub trait Real:
    Float + FloatConst + FromPrimitive + Debug + Display + Default + Send + Sync + 'static
{
    /// Converts an `f64` literal or coefficient to this type (rounding to nearest).
    #[inline(always)]
    fn lit(v: f64) -> Self {
        // Through `NumCast`: some extended-precision types only implement the integer
        // conversions of `FromPrimitive`, whose default `from_f64` truncates.
        <Self as num_traits::NumCast>::from(v).unwrap_or_else(Self::nan)
    }

    /// Converts to `f64` for reports and error values.
    #[inline(always)]
    fn to_f64_lossy(self) -> f64 {
        num_traits::ToPrimitive::to_f64(&self).unwrap_or(f64::NAN)
    }
}

impl<T> Real for T where
    T: Float + FloatConst + FromPrimitive + Debug + Display + Default + Send + Sync + 'static
{
}
