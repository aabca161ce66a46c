//! Parameter values: grids (linear or logarithmic) and seeded random draws (SplitMix64).

use super::{bad, file::GridSpec};
use lieflow::scene::SceneError;

/// SplitMix64: a 64-bit state advanced by a Weyl sequence and mixed (Steele, Lea & Flood 2014).
pub(crate) struct SplitMix(pub(crate) u64);

impl SplitMix {
    pub(crate) fn next_f64(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

pub(crate) fn grid_values(g: &GridSpec, path: &str) -> Result<Vec<f64>, SceneError> {
    if g.count == 0 || !g.from.is_finite() || !g.to.is_finite() {
        return Err(bad(format!(
            "parameter '{path}': a grid needs count >= 1 and finite ends"
        )));
    }
    let n = g.count;
    let t = |i: usize| {
        if n == 1 {
            0.0
        } else {
            i as f64 / (n - 1) as f64
        }
    };
    match g.scale.as_str() {
        "linear" => Ok((0..n).map(|i| g.from + (g.to - g.from) * t(i)).collect()),
        "log" if g.from > 0.0 && g.to > 0.0 => {
            let (a, b) = (g.from.ln(), g.to.ln());
            // The ends exactly as written; the interior geometrically.
            Ok((0..n)
                .map(|i| match i {
                    0 => g.from,
                    _ if i + 1 == n => g.to,
                    _ => (a + (b - a) * t(i)).exp(),
                })
                .collect())
        }
        "log" => Err(bad(format!(
            "parameter '{path}': a log grid needs positive ends"
        ))),
        s => Err(bad(format!(
            "parameter '{path}': unknown scale '{s}' (linear or log)"
        ))),
    }
}
