//! An enum whose variants are flows is a flow: every [`Flow`](super::Flow) method is that of the
//! variant held.
//!
//! A wrapper generic over its inner flow (the projection, a composition, an extrapolation) is
//! compiled in full for every inner type it is given. Where a caller picks one of a few inner
//! flows at run time (a scene's splitting: the free flight alone, or kicks around it), an enum of
//! them is one inner type instead of several: one branch per call on the variant, which stays
//! the same for the whole run, instead of one more copy of the wrapper.

/// Declares `enum $name<V: Vector> { $variant($flow), … }` and its [`Flow<V>`](super::Flow)
/// implementation, each method forwarded to the variant held (fully qualified, so a variant
/// generic over the state type, like a scene's kick, resolves to `V`).
// Used by the scenes' splitting (feature `scene`) and this module's test.
#[cfg_attr(not(feature = "scene"), allow(unused_macros))]
macro_rules! flow_enum {
    (
        $(#[$meta:meta])*
        $vis:vis enum $name:ident<V> {
            $($(#[$vmeta:meta])* $variant:ident($flow:ty)),+ $(,)?
        }
    ) => {
        $(#[$meta])*
        $vis enum $name<V: $crate::vector::Vector> {
            $($(#[$vmeta])* $variant($flow)),+
        }

        impl<V: $crate::vector::Vector> core::fmt::Debug for $name<V> {
            fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                match self {
                    $($name::$variant(_) => f.write_str(concat!(stringify!($name), "::", stringify!($variant)))),+
                }
            }
        }

        impl<V: $crate::vector::Vector> $crate::flow::Flow<V> for $name<V> {
            #[inline]
            fn step(&mut self, h: V::Real, x: &mut V) -> Result<(), $crate::error::StepError> {
                match self { $($name::$variant(f) => $crate::flow::Flow::<V>::step(f, h, x)),+ }
            }
            fn order(&self) -> u32 {
                match self { $($name::$variant(f) => $crate::flow::Flow::<V>::order(f)),+ }
            }
            fn is_symmetric(&self) -> bool {
                match self { $($name::$variant(f) => $crate::flow::Flow::<V>::is_symmetric(f)),+ }
            }
            fn prepare(&mut self, x: &V) {
                match self { $($name::$variant(f) => $crate::flow::Flow::<V>::prepare(f, x)),+ }
            }
            fn stats(&self) -> $crate::flow::FlowStats {
                match self { $($name::$variant(f) => $crate::flow::Flow::<V>::stats(f)),+ }
            }
            fn multipliers(&self) -> Option<$crate::flow::Multipliers<'_, V::Real>> {
                match self { $($name::$variant(f) => $crate::flow::Flow::<V>::multipliers(f)),+ }
            }
            fn is_fallible(&self) -> bool {
                match self { $($name::$variant(f) => $crate::flow::Flow::<V>::is_fallible(f)),+ }
            }
            fn dissipates(&self) -> bool {
                match self { $($name::$variant(f) => $crate::flow::Flow::<V>::dissipates(f)),+ }
            }
            fn step_table_is_atomic(&self) -> bool {
                match self {
                    $($name::$variant(f) => $crate::flow::Flow::<V>::step_table_is_atomic(f)),+
                }
            }
            fn tangent_apply(&mut self, v: &V, out: &mut V) -> bool {
                match self {
                    $($name::$variant(f) => $crate::flow::Flow::<V>::tangent_apply(f, v, out)),+
                }
            }
            fn is_kick(&self) -> bool {
                match self { $($name::$variant(f) => $crate::flow::Flow::<V>::is_kick(f)),+ }
            }
            #[inline]
            fn step_lead(
                &mut self,
                ledger: &mut $crate::flow::Ledger<V::Real>,
                h: V::Real,
                x: &mut V,
            ) -> Result<(), $crate::error::StepError> {
                match self {
                    $($name::$variant(f) => $crate::flow::Flow::<V>::step_lead(f, ledger, h, x)),+
                }
            }
            #[inline]
            fn step_tail(
                &mut self,
                ledger: &mut $crate::flow::Ledger<V::Real>,
                h: V::Real,
                x: &mut V,
            ) -> Result<(), $crate::error::StepError> {
                match self {
                    $($name::$variant(f) => $crate::flow::Flow::<V>::step_tail(f, ledger, h, x)),+
                }
            }
            fn lead_tangent_apply(&mut self, v: &V, out: &mut V) -> bool {
                match self {
                    $($name::$variant(f) => $crate::flow::Flow::<V>::lead_tangent_apply(f, v, out)),+
                }
            }
            fn lead_is_affine(&self) -> bool {
                match self { $($name::$variant(f) => $crate::flow::Flow::<V>::lead_is_affine(f)),+ }
            }
            fn lead_ledger_is_constant(&self) -> bool {
                match self {
                    $($name::$variant(f) => $crate::flow::Flow::<V>::lead_ledger_is_constant(f)),+
                }
            }
            fn is_affine_in_momenta(&self) -> bool {
                match self {
                    $($name::$variant(f) => $crate::flow::Flow::<V>::is_affine_in_momenta(f)),+
                }
            }
            fn lead_is_affine_in_momenta(&self) -> bool {
                match self {
                    $($name::$variant(f) => $crate::flow::Flow::<V>::lead_is_affine_in_momenta(f)),+
                }
            }
            #[inline]
            fn step_at(
                &mut self,
                ledger: &mut $crate::flow::Ledger<V::Real>,
                h: V::Real,
                x: &mut V,
            ) -> Result<(), $crate::error::StepError> {
                match self {
                    $($name::$variant(f) => $crate::flow::Flow::<V>::step_at(f, ledger, h, x)),+
                }
            }
            fn step_table(
                &mut self,
                ledger: &mut $crate::flow::Ledger<V::Real>,
                h: V::Real,
                table: &$crate::flow::CompositionTable,
                x: &mut V,
            ) -> Result<(), $crate::error::StepError> {
                match self {
                    $($name::$variant(f) => $crate::flow::Flow::<V>::step_table(f, ledger, h, table, x)),+
                }
            }
            fn step_repeated(
                &mut self,
                ledger: &mut $crate::flow::Ledger<V::Real>,
                h: V::Real,
                n: u32,
                x: &mut V,
            ) -> Result<(), $crate::error::StepError> {
                match self {
                    $($name::$variant(f) => $crate::flow::Flow::<V>::step_repeated(f, ledger, h, n, x)),+
                }
            }
            fn save_memory(&mut self, out: &mut Vec<V::Real>) {
                match self { $($name::$variant(f) => $crate::flow::Flow::<V>::save_memory(f, out)),+ }
            }
            fn restore_memory(&mut self, from: &mut &[V::Real]) {
                match self {
                    $($name::$variant(f) => $crate::flow::Flow::<V>::restore_memory(f, from)),+
                }
            }
        }
    };
}

#[cfg_attr(not(feature = "scene"), allow(unused_imports))]
pub(crate) use flow_enum;

#[cfg(test)]
mod tests {
    use crate::error::StepError;
    use crate::flow::{EXACT, Flow, Ledger, from_fn_with_order};
    use crate::real::Real;
    use crate::vector::Vector;
    use nalgebra::SVector;

    type V1 = SVector<f64, 1>;

    /// `x' = a x`, exactly, for any state type of scalar `T` (as a scene's kick is).
    struct Grow<T>(T);

    impl<T: Real, V: Vector<Real = T>> Flow<V> for Grow<T> {
        fn step(&mut self, h: T, x: &mut V) -> Result<(), StepError> {
            for c in x.as_mut_slice() {
                *c = *c * (self.0 * h).exp();
            }
            Ok(())
        }
        fn order(&self) -> u32 {
            EXACT
        }
        fn is_symmetric(&self) -> bool {
            true
        }
    }

    super::flow_enum! {
        /// An exact flow generic over the state, or any flow behind a pointer.
        enum Either<V> {
            Exact(Grow<V::Real>),
            Boxed(Box<dyn Flow<V>>),
        }
    }

    /// Each variant steps, and reports its order and symmetry, as the flow it holds.
    #[test]
    fn a_flow_enum_is_the_flow_it_holds() {
        let mut exact: Either<V1> = Either::Exact(Grow(2.0));
        let euler = from_fn_with_order(|h: f64, x: &mut V1| x[0] *= 1.0 + 3.0 * h, 1, false);
        let mut boxed: Either<V1> = Either::Boxed(Box::new(euler));
        assert_eq!((exact.order(), exact.is_symmetric()), (EXACT, true));
        assert_eq!((boxed.order(), boxed.is_symmetric()), (1, false));
        let (mut a, mut b) = (V1::new(1.0), V1::new(1.0));
        exact.step_at(&mut Ledger::default(), 0.5, &mut a).unwrap();
        boxed.step(0.5, &mut b).unwrap();
        assert_eq!(a[0], 1.0f64.exp());
        assert_eq!(b[0], 2.5);
        assert_eq!(format!("{exact:?}"), "Either::Exact");
    }
}
