//! The integration tests of plumbline-navigation, one module per subject, linked into one binary.

mod accuracy;
mod adaptive;
mod consistency;
mod integrity;
