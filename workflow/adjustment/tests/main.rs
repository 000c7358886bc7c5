//! The integration tests of plumbline-adjustment, one module per subject, linked into one binary. The schema
//! staleness check is its own target, `schemas`, so that this regenerates the schemas:
//! `PLUMBLINE_UPDATE_SCHEMAS=1 cargo test -p plumbline-adjustment --test schemas`.

mod jumps;
mod kinematics;
mod localize;
mod motions;
mod poles;
mod ray_sigma;
mod standstill;
mod ties;
