//! The integration tests of plumbline-adjuster, one module per subject, linked into one binary.

mod finish;
mod report;
mod solve;
