//! The integration tests of plumbline-registration, one module per subject, linked into one binary. The schema
//! staleness check is its own target, `schemas`, so that this regenerates the schemas:
//! `PLUMBLINE_UPDATE_SCHEMAS=1 cargo test -p plumbline-registration --test schemas`.

mod tiny;
