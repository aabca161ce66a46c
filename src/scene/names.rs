//! Enumerations whose values have names in scene files (schemes, flags, diagnostics, the
//! redundancy policy): each name is written once, beside its variant; parsing (serde),
//! printing and the list of valid names in error messages all come from that one declaration.

use crate::flow::CompositionTable;
use crate::flow::coefficients::table_by_name;

/// Declares a `Copy` enum whose variants deserialize from, and print as, the given names, with
/// `ALL`, `name`, `from_name` and `names` (the list for error messages).
macro_rules! named_enum {
    (
        $(#[$meta:meta])*
        $vis:vis enum $Name:ident {
            $( $(#[doc = $doc:literal])* $Variant:ident = $name:literal, )+
        }
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Deserialize)]
        $vis enum $Name {
            $( $(#[doc = $doc])* #[serde(rename = $name)] $Variant, )+
        }

        impl $Name {
            /// Every value, in declaration order.
            pub const ALL: &'static [$Name] = &[$($Name::$Variant,)+];

            /// The name in scene files.
            pub fn name(self) -> &'static str {
                match self {
                    $($Name::$Variant => $name,)+
                }
            }

            /// The value called `name`, if there is one.
            pub fn from_name(name: &str) -> Option<Self> {
                Self::ALL.iter().copied().find(|v| v.name() == name)
            }

            /// The valid names, comma-separated (for error messages).
            pub fn names() -> String {
                Self::ALL.iter().map(|v| v.name()).collect::<Vec<_>>().join(", ")
            }
        }

        impl core::fmt::Display for $Name {
            fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                f.write_str(self.name())
            }
        }
    };
}

named_enum! {
    /// The integrator of a scene (`integrator.scheme`).
    pub enum Method {
        /// The splitting of the declared effects, composed to `order` (default 2).
        Auto = "auto",
        /// The splitting itself (Strang, order 2).
        Strang = "strang",
        /// Yoshida's triple jump (order 4).
        TripleJump = "triple-jump",
        /// Suzuki's five-stage composition (order 4).
        Suzuki4 = "suzuki4",
        /// Yoshida's order-6 composition.
        Yoshida6 = "yoshida6",
        /// Kahan and Li's order-6 composition.
        KahanLi6 = "kahan-li6",
        /// Suzuki and Umeno's order-8 composition.
        SuzukiUmeno8 = "suzuki-umeno8",
        /// Kahan and Li's order-8 composition.
        KahanLi8 = "kahan-li8",
        /// Extrapolation of the splitting to `order` (default 4), every sub-step forward.
        Extrapolation = "extrapolation",
        /// Gonzalez's discrete gradient (order 2, implicit).
        DiscreteGradient = "discrete-gradient",
        /// The energy-consistent Petrov–Galerkin scheme (`order` 2, 4, 6, 8; default 4;
        /// implicit, exact discrete energy balance).
        PetrovGalerkin = "petrov-galerkin",
        /// The implicit midpoint rule, projected (order 2).
        Midpoint = "midpoint",
        /// The paper's §2 scheme (built-in paper model only).
        Modified = "modified",
    }
}

// The default is named in the variant list's documentation; the enum is declared by a macro.
#[allow(clippy::derivable_impls)]
impl Default for Method {
    fn default() -> Self {
        Method::Auto
    }
}

impl Method {
    /// The composition table of a named composition (`None` for `auto`, `strang` and the
    /// implicit schemes).
    pub fn composition(self) -> Option<&'static CompositionTable> {
        match self {
            Method::TripleJump
            | Method::Suzuki4
            | Method::Yoshida6
            | Method::KahanLi6
            | Method::SuzukiUmeno8
            | Method::KahanLi8 => table_by_name(self.name()),
            Method::Auto
            | Method::Strang
            | Method::Extrapolation
            | Method::DiscreteGradient
            | Method::PetrovGalerkin
            | Method::Midpoint
            | Method::Modified => None,
        }
    }
}

named_enum! {
    /// How steps are chosen for a tolerance (`integrator.controller`).
    pub enum Controller {
        /// To meet the tolerance: the adaptive extrapolation of the splitting, or step
        /// doubling of a named fixed-order scheme.
        Error = "error",
        /// Time-reversible steps along `integrator.density` (conservative splittings only).
        Reversible = "reversible",
    }
}

named_enum! {
    /// A diagnostic computed after every step (`integrator.diagnostics`).
    pub enum Diagnostic {
        /// `H`, and with damping the energy budget.
        Energy = "energy",
        /// `|g|` and `|φ|`.
        Constraints = "constraints",
        /// The time spent in each effect.
        Profile = "profile",
    }
}

named_enum! {
    /// What to do with redundant constraints (`integrator.redundant`).
    pub enum Redundant {
        /// Refuse the scene, naming a dependent constraint.
        Refuse = "refuse",
        /// Drop dependent single-row constraints and report which.
        DropDependent = "drop-dependent",
    }
}

#[allow(clippy::derivable_impls)]
impl Default for Redundant {
    fn default() -> Self {
        Redundant::Refuse
    }
}

named_enum! {
    /// A switch of `[flags]` (and of the command's `--off`).
    pub enum Flag {
        /// Gravity effects.
        Gravity = "gravity",
        /// Spring effects.
        Springs = "springs",
        /// Pair potentials.
        Pair = "pair",
        /// Traps.
        Trap = "trap",
        /// Damping.
        Damping = "damping",
        /// Magnetic fields.
        Magnetic = "magnetic",
        /// Every constraint.
        Constraints = "constraints",
        /// The energy diagnostic.
        Energy = "energy",
        /// The constraint-residual diagnostic.
        Residuals = "residuals",
    }
}

#[cfg(test)]
mod tests {
    use super::Method;

    /// Every named composition resolves to the coefficient table of the same name (a name that
    /// did not would silently run Strang).
    #[test]
    fn named_compositions_resolve_to_their_tables() {
        for &m in Method::ALL {
            let table = m.composition();
            match m {
                Method::Auto
                | Method::Strang
                | Method::Extrapolation
                | Method::DiscreteGradient
                | Method::PetrovGalerkin
                | Method::Midpoint
                | Method::Modified => assert!(table.is_none(), "{m}"),
                _ => assert_eq!(table.map(|t| t.name), Some(m.name()), "{m}"),
            }
        }
    }
}
