//! Scene files compiled and run: their effects, errors, orders, storages and the paths their
//! multiplier solves take.
//!
//! One test binary for the suite (a module a file): the generic code the files share is
//! compiled and linked once.

#[path = "../common/mod.rs"]
mod common;
#[path = "../common/scene_text.rs"]
mod scene_text;

mod diagonal_path;
mod kick_tail;
mod mechanical_discrete_gradient;
mod mechanical_form;
mod scene;
mod scene_accepted_steps;
mod scene_books;
mod scene_breakpoints;
mod scene_bricard;
mod scene_controllers;
mod scene_damping_account;
mod scene_dense;
mod scene_errors;
mod scene_flight;
mod scene_governor;
mod scene_hidden;
mod scene_hinge_limit;
mod scene_implicit_inputs;
mod scene_joint_elements;
mod scene_joint_position;
mod scene_modelling;
mod scene_planar;
mod scene_ports;
mod scene_rigid;
mod scene_servo;
mod scene_sketch;
mod scene_slider_force;
mod scene_slider_limit;
mod scene_slider_spring;
mod scene_taut_chain;
mod scene_tolerance;
mod scene_unconstrained;
mod scene_weld;
