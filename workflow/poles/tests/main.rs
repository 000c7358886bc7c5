//! The integration tests of plumbline-poles, one module per subject, linked into one binary. The schema
//! staleness check is its own target, `schemas`, so that this regenerates the schemas:
//! `PLUMBLINE_UPDATE_SCHEMAS=1 cargo test -p plumbline-poles --test schemas`.

mod depth;
mod las;
mod matching;
mod synthetic;
