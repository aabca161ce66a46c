//! Symmetric composition coefficient tables `γ₁ … γ_s` (`γ_{s+1−i} = γ_i`).
//!
//! Composing a symmetric method `Φ_h` of order 2 as `Φ_{γ_s h} ∘ … ∘ Φ_{γ_1 h}` raises the order
//! to the table's order (Yoshida 1990; McLachlan 1995; Kahan & Li 1997; GNI §V.3.2). Values as
//! tabulated in Hairer's GniCodes; `tests/flows/coefficients.rs` checks `Σγ = 1` and the order conditions.
//!
//! Every table above order 2 has negative entries: applied to a flow with dissipation, a
//! negative sub-step runs the dissipation backwards.

/// A symmetric composition: `stages` coefficients, given up to and including the middle one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompositionTable {
    /// Short name, also used on command lines (`"triple-jump"`, `"suzuki4"`, …).
    pub name: &'static str,
    /// Order reached from a symmetric method of order 2.
    pub order: u32,
    /// Number of stages `s`.
    pub stages: usize,
    /// `γ₁ … γ_{(s+1)/2}` rounded to `f64`; the rest follow by symmetry.
    pub half: &'static [f64],
    /// The rounding errors of [`half`](Self::half): `γ_i ≈ half[i] + half_lo[i]` to about 27
    /// digits, so extended-precision scalars get coefficients that satisfy the order conditions
    /// to their own precision (for `f64` the sum rounds to `half[i]`).
    pub half_lo: &'static [f64],
    /// Where the coefficients come from.
    pub reference: &'static str,
}

impl CompositionTable {
    /// The coefficient `γ_{i+1}` of stage `i` (0-based).
    #[inline(always)]
    pub fn gamma(&self, i: usize) -> f64 {
        self.half[i.min(self.stages - 1 - i)]
    }

    /// The coefficient `γ_{i+1}` in the scalar type `T`, to the precision of `T` (up to ~27 digits).
    #[inline(always)]
    pub fn gamma_in<T: crate::Real>(&self, i: usize) -> T {
        let j = i.min(self.stages - 1 - i);
        let hi = T::lit(self.half[j]);
        // For a type no finer than `f64` the low part rounds away (the branch folds at compile
        // time): no load and no addition in the step.
        if T::epsilon() >= T::lit(f64::EPSILON) {
            hi
        } else {
            hi + T::lit(self.half_lo[j])
        }
    }

    /// All `s` coefficients, in order.
    pub fn gammas(&self) -> impl Iterator<Item = f64> + '_ {
        (0..self.stages).map(|i| self.gamma(i))
    }

    /// `true` if some coefficient is negative (a backward sub-step).
    pub fn has_negative_steps(&self) -> bool {
        self.half.iter().any(|&g| g < 0.0)
    }
}

/// Yoshida's triple jump, order 4, 3 stages: `γ₁ = 1/(2 − 2^{1/3})`, `γ₂ = −2^{1/3}/(2 − 2^{1/3})`.
/// H. Yoshida, Phys. Lett. A 150 (1990) 262–268; also Suzuki (1990), Creutz & Gocksch (1989).
pub const TRIPLE_JUMP: CompositionTable = CompositionTable {
    name: "triple-jump",
    order: 4,
    stages: 3,
    half: &[1.3512071919596575, -1.7024143839193153],
    half_lo: &[8.42741775545176e-17, 5.349624981599612e-17],
    reference: "H. Yoshida, Phys. Lett. A 150 (1990) 262-268",
};

/// Suzuki's fractal composition, order 4, 5 stages: `γ₁ = γ₂ = 1/(4 − 4^{1/3})`,
/// `γ₃ = −4^{1/3}/(4 − 4^{1/3})`. M. Suzuki, Phys. Lett. A 146 (1990) 319–323.
pub const SUZUKI4: CompositionTable = CompositionTable {
    name: "suzuki4",
    order: 4,
    stages: 5,
    half: &[0.4144907717943757, 0.4144907717943757, -0.657963087177503],
    half_lo: &[
        2.5197374150855977e-17,
        2.5197374150855977e-17,
        1.023280585909174e-17,
    ],
    reference: "M. Suzuki, Phys. Lett. A 146 (1990) 319-323",
};

/// Yoshida's order-6 composition with 7 stages (his "solution A").
/// H. Yoshida, Phys. Lett. A 150 (1990) 262–268.
pub const YOSHIDA6: CompositionTable = CompositionTable {
    name: "yoshida6",
    order: 6,
    stages: 7,
    half: &[
        0.7845136104775573,
        0.23557321335935813,
        -1.177679984178871,
        1.3151863206839112,
    ],
    half_lo: &[
        -3.5563524752244235e-17,
        3.5702639627194945e-18,
        -2.0335583674318997e-17,
        4.9146537686429645e-17,
    ],
    reference: "H. Yoshida, Phys. Lett. A 150 (1990) 262-268",
};

/// Kahan and Li's order-6 composition with 9 stages.
/// W. Kahan, R.-C. Li, Math. Comp. 66 (1997) 1089–1099.
pub const KAHAN_LI6: CompositionTable = CompositionTable {
    name: "kahan-li6",
    order: 6,
    stages: 9,
    half: &[
        0.3921584622655814,
        0.33260288849639386,
        -0.7062460735923008,
        0.08221272729243641,
        0.7985439910757786,
    ],
    half_lo: &[
        -2.1723614144229618e-17,
        -2.739845775510275e-17,
        -3.610734528820911e-17,
        2.3491828086268915e-18,
        2.698259067968461e-17,
    ],
    reference: "W. Kahan, R.-C. Li, Math. Comp. 66 (1997) 1089-1099",
};

/// Suzuki and Umeno's order-8 composition with 15 stages (as in GNI §V.3.2, from McLachlan 1995).
/// M. Suzuki, K. Umeno, in *Computer Simulation Studies in Condensed-Matter Physics VI*, Springer 1993.
pub const SUZUKI_UMENO8: CompositionTable = CompositionTable {
    name: "suzuki-umeno8",
    order: 8,
    stages: 15,
    half: &[
        0.741670364350613,
        -0.4091008258000316,
        0.1907547102962384,
        -0.5738624711160822,
        0.2990641813036559,
        0.33462491824529816,
        0.3152930923967666,
        -0.7968879393529164,
    ],
    half_lo: &[
        -5.148655322769124e-19,
        3.8036097216716665e-18,
        -8.968542234075828e-18,
        -2.662617822523361e-17,
        5.612964695238482e-18,
        1.9697115983338846e-17,
        -1.9948748815678063e-17,
        -1.6218624372269903e-18,
    ],
    reference: "M. Suzuki, K. Umeno (1993); R. I. McLachlan, SIAM J. Sci. Comput. 16 (1995)",
};

/// Kahan and Li's order-8 composition with 17 stages.
/// W. Kahan, R.-C. Li, Math. Comp. 66 (1997) 1089–1099.
pub const KAHAN_LI8: CompositionTable = CompositionTable {
    name: "kahan-li8",
    order: 8,
    stages: 17,
    half: &[
        0.13020248308889007,
        0.5611629817751084,
        -0.38947496264484727,
        0.1588419065551556,
        -0.39590389413323757,
        0.1845396409783157,
        0.25837438768632204,
        0.2950117236093103,
        -0.6055085338300346,
    ],
    half_lo: &[
        1.1160926478587086e-17,
        1.3032594121955553e-17,
        -1.9606416555400348e-17,
        7.801358343533911e-18,
        -1.1269790435660099e-17,
        -3.914442028717345e-18,
        9.400318801672474e-18,
        2.648390331662844e-17,
        4.4845398377316304e-17,
    ],
    reference: "W. Kahan, R.-C. Li, Math. Comp. 66 (1997) 1089-1099",
};

/// Every table above, for lookup by name.
pub const ALL_TABLES: &[&CompositionTable] = &[
    &TRIPLE_JUMP,
    &SUZUKI4,
    &YOSHIDA6,
    &KAHAN_LI6,
    &SUZUKI_UMENO8,
    &KAHAN_LI8,
];

/// Finds a table by its [`name`](CompositionTable::name).
pub fn table_by_name(name: &str) -> Option<&'static CompositionTable> {
    ALL_TABLES.iter().copied().find(|t| t.name == name)
}
