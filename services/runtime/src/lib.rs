//! Service runtime shared by every plumbline process: config, object store, CRS transforms, tracing.
//!
//! Architecture invariant: this crate is an edge crate. It is the only place that holds GDAL
//! spatial-reference handles and builds object stores from URLs, so that `workflow/*` stays free of
//! I/O, GDAL and the environment. Nothing here reads the process environment: callers pass the
//! environment map (config) or the `RUST_LOG` value (tracing) in.
//!
//! - [`config`] — [`RuntimeConfig::load`] from TOML bytes plus an environment map.
//! - [`store`] — [`open_store`] from a `file://`, `memory://`, `s3://` URL or a plain path;
//!   [`read_url`] / [`write_url`] for one object named by URL.
//! - [`crs`] — [`CrsTransform`] between EPSG codes, [`meridian_convergence`].
//! - [`gdal_read`] / [`gdal_write`] — raster windows ([`gdal_read::RasterSource`]), GeoTIFF and GeoPackage encoding;
//!   agency rasters open only through an allow-list of GDAL drivers, agency VRTs only as [`vrt::VrtMosaic`]s rewritten
//!   to the files beside them; [`line_io`] — line layers read back from a GeoPackage and written as GeoJSON.
//! - [`files`] — [`Files`]: whole files by path or URL; [`errors`] — [`Error`] with its [`ErrorKind`] (invalid, missing, forbidden, transient, internal), what callers decide exit codes, retries and skips on.
//! - [`trajectory`] — trajectory files (CSV, SBET + smrmsg) into the campaign CRS and back.
//! - [`ops`] — the roles' metrics registry, ops listener (`/healthz`, `/readyz`, `/metrics`) and JetStream
//!   heartbeat.
//! - [`logging`] — [`init_tracing`], with OTLP span export through [`telemetry`]; [`progress`] — bars, log
//!   lines or JSON lines for long work.

pub mod cadastre;
pub mod config;
pub mod crs;
pub mod errors;
pub mod files;
pub mod gdal_messages;
pub mod gdal_read;
pub mod gdal_write;
pub mod line_io;
pub mod logging;
pub mod ops;
pub mod progress;
pub mod range_reader;
mod raster_common;
pub mod secret;
pub mod spill;
pub mod store;
pub mod telemetry;
pub mod trajectory;
pub mod vrt;

pub use config::{ConfigError, LogConfig, LogFormat, NatsConfig, RuntimeConfig, StoreConfig};
pub use crs::{
    CrsError, CrsTransform, MeridianConvergence, crs_name, epsg_of_wkt, is_projected, linear_unit_m,
    meridian_convergence, vertical_unit_of_wkt,
};
pub use errors::{Context, Error, ErrorKind, OrInvalid, Result, find_error, invalid, is_invalid};
pub use files::{Files, file_name};
pub use logging::{TracingError, TracingGuard, init_tracing};
pub use range_reader::RangeReader;
pub use secret::Secret;
pub use store::{
    GdalRemote, PART_SIZE, S3Options, StoreError, StoreErrorKind, StoreRoot, StreamingUpload, gdal_remote, get_bytes,
    head_url, open_store, put_bytes, read_url, write_url,
};
pub use telemetry::{OtlpExport, Telemetry, TelemetryError};
