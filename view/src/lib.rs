//! The animation page of a lieflow run: one self-contained HTML file that plays the motion of
//! a scene in any current browser, offline.
//!
//! A [`Recorder`] observes a run's samples ([`lieflow::scene::Sample`]) and keeps frames at the
//! display rate — the positions of every slot of the state as `f32`, the times and steps, the
//! declared outputs and the energy — within a size budget ([`FrameBudget`]); [`write_page`]
//! writes them with the scene's [`Sketch`](lieflow::scene::sketch::Sketch) (what to draw),
//! the run's events and three.js into one HTML file. The page draws points as spheres sized by
//! mass, rigid bodies as their solid with their axes, rods, joints, springs and dashpots as
//! lines and coils, constraint surfaces faintly and the paths of chosen bodies; it plays,
//! pauses, scrubs and changes speed, orbits, pans and zooms in 3D (a fixed view of the plane in
//! 2D), plots the outputs beside the view and marks the events on the time line.
//!
//! three.js (MIT, <https://threejs.org>) is vendored as `assets/three.min.js`, the part the
//! page uses bundled from the npm package by `assets/bundle.sh`, and inlined into every page:
//! nothing is fetched when the page is viewed. The library (`cargo add lieflow`) does not
//! carry the page; the command and the Python package do, through this crate.

mod base64;
mod page;
mod recorder;

pub use page::{PageInfo, write_page};
pub use recorder::{FrameBudget, Recorder, RecorderError};

#[cfg(test)]
mod budget_tests;
