//! The integration tests of plumbline-synth, one module per subject, linked into one binary.

mod city;
mod city_aerial;
mod motion_dg;
mod motion_drive;
mod motion_overview;
mod motion_sensors;
mod motion_world;
mod render;
mod render_aerial;
mod render_block;
mod render_light;
mod render_truth;
mod world;
mod world_route;
mod world_texture;
