//! What a compiled scene is, as one number: checkpoints carry it, and a checkpoint of another
//! scene is refused at restore.

use super::Assembly;
use crate::scene::Simulation;

/// FNV-1a (64 bit) of the compiled scene's structure: its name, bodies and state columns,
/// constraint rows by label, inputs and scheme — not its parameter values nor which force
/// terms act (a damper set to zero leaves the model), which
/// [`set_parameter`](crate::scene::set_parameter) changes on a running scene (its checkpoint
/// moves into the recompiled one). Stable across runs and builds (no random keys).
pub(super) fn fingerprint(assembly: &Assembly, simulation: &dyn Simulation) -> u64 {
    let mut hash = 0xcbf2_9ce4_8422_2325u64;
    let mut eat = |text: &str| {
        // A separator after each field, so that ("ab", "c") and ("a", "bc") differ.
        for b in text.bytes().chain([0xff]) {
            hash ^= u64::from(b);
            hash = hash.wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    eat(&assembly.name);
    eat(&format!(
        "{:?} {} {}",
        assembly.dim, assembly.bodies, assembly.state_len
    ));
    simulation.state_names().iter().for_each(|n| eat(n));
    simulation.multiplier_names().iter().for_each(|n| eat(n));
    for (name, what) in &assembly.inputs {
        eat(name);
        eat(what);
    }
    eat(&assembly.scheme);
    eat(&assembly.order.to_string());
    hash
}
