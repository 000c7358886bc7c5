//! The integration tests of plumbline-runtime, one module per subject, linked into one binary. The two that
//! install the process-wide tracing subscriber, `tracing_init` and `otlp_export`, are targets of their own.

mod cadastre;
mod config;
mod crs;
mod gdal_write;
mod store_local;
mod store_s3;
