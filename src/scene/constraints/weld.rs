//! `type = "weld"`: two bodies fixed to one another. A weld declares no rows: the compiler
//! merges the welded bodies into one rigid body before the run (`scene/compile/weld.rs`,
//! `crate::rigid::weld`), which is what a weld means and costs nothing a step.

use super::{Declare, Declared};
use crate::scene::bodies::Bodies;
use crate::scene::error::FieldPath;
use crate::scene::validate::Result;
use serde::Deserialize;

/// A weld between two bodies declared in `[[bodies]]`, at least one of a group of welded bodies
/// rigid. The group becomes one rigid body named after its first-declared member, its centre the
/// group's centre of mass, its frame that member's; anchors and axes given in a member's frame
/// are carried to it; effects, outputs and events name the merged body.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WeldSpec {
    /// A name: the weld's label in messages, and what `--off NAME` switches off (the bodies
    /// then move apart).
    #[serde(default)]
    pub name: Option<String>,
    /// The two bodies.
    pub bodies: Vec<String>,
}

impl Declare for WeldSpec {
    /// Nothing: the weld was applied when the bodies were built.
    fn declare(
        &self,
        _i: usize,
        _path: &FieldPath,
        _bodies: &Bodies,
        _out: &mut Vec<Declared>,
    ) -> Result<()> {
        Ok(())
    }
}
