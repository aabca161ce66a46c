//! Symmetric composition coefficient tables `γ₁ … γ_s` (`γ_{s+1−i} = γ_i`).
//!
//! Composing a symmetric method `Φ_h` of order 2 as `Φ_{γ_s h} ∘ … ∘ Φ_{γ_1 h}` raises the order
//! to the table's order (Yoshida 1990; McLachlan 1995; Kahan & Li 1997; GNI §V.3.2). Values as
//! tabulated in Hairer's GniCodes; `tests/coefficients.rs` checks `Σγ = 1` and the order conditions.
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
    /// `γ₁ … γ_{(s+1)/2}`; the rest follow by symmetry.
    pub half: &'static [f64],
    /// Where the coefficients come from.
    pub reference: &'static str,
}

impl CompositionTable {
    /// The coefficient `γ_{i+1}` of stage `i` (0-based).
    #[inline(always)]
    pub fn gamma(&self, i: usize) -> f64 {
        self.half[i.min(self.stages - 1 - i)]
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
    half: &[1.351_207_191_959_657_6, -1.702_414_383_919_315_3],
    reference: "H. Yoshida, Phys. Lett. A 150 (1990) 262-268",
};

/// Suzuki's fractal composition, order 4, 5 stages: `γ₁ = γ₂ = 1/(4 − 4^{1/3})`,
/// `γ₃ = −4^{1/3}/(4 − 4^{1/3})`. M. Suzuki, Phys. Lett. A 146 (1990) 319–323.
pub const SUZUKI4: CompositionTable = CompositionTable {
    name: "suzuki4",
    order: 4,
    stages: 5,
    half: &[
        0.414_490_771_794_375_7,
        0.414_490_771_794_375_7,
        -0.657_963_087_177_502_9,
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
        0.784_513_610_477_557_3,
        0.235_573_213_359_358_1,
        -1.177_679_984_178_871,
        1.315_186_320_683_911_2,
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
        0.392_158_462_265_581_35,
        0.332_602_888_496_393_83,
        -0.706_246_073_592_300_9,
        0.082_212_727_292_436_41,
        0.798_543_991_075_778_6,
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
        0.741_670_364_350_612_9,
        -0.409_100_825_800_031_6,
        0.190_754_710_296_238_38,
        -0.573_862_471_116_082_3,
        0.299_064_181_303_655_9,
        0.334_624_918_245_298_2,
        0.315_293_092_396_766_6,
        -0.796_887_939_352_914,
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
        0.130_202_483_088_890_08,
        0.561_162_981_775_108_4,
        -0.389_474_962_644_847_3,
        0.158_841_906_555_155_6,
        -0.395_903_894_133_237_6,
        0.184_539_640_978_315_7,
        0.258_374_387_686_322,
        0.295_011_723_609_310_3,
        -0.605_508_533_830_034_5,
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
