//! Whole files named by path or object-store URL, with the store credentials of the runtime config.

use bytes::Bytes;

use crate::errors::{Context as _, Error, Result};
use crate::gdal_read::PixelInput;
use crate::store::StoreLocation;
use crate::store::{
    GdalRemote, S3Options, StoreErrorKind, gdal_remote, head_url, read_url, read_url_prefix, read_url_range,
    size_of_url, write_url,
};

/// Reads and writes files by path or URL (`file://`, `s3://`, plain paths).
#[derive(Clone, Debug, Default)]
pub struct Files {
    s3: S3Options,
}

impl Files {
    /// Files reached with these S3 settings.
    pub fn new(s3: S3Options) -> Self {
        Self { s3 }
    }

    /// The S3 settings.
    pub fn s3(&self) -> &S3Options {
        &self.s3
    }

    /// Read a whole file. A missing file is invalid input naming it.
    pub async fn read(&self, url: &str) -> Result<Bytes> {
        read_url(url, &self.s3).await.map_err(|e| missing_named(url, e))
    }

    /// The first `max` bytes of a file (fewer when it is shorter) and its total size, with one range read. A
    /// missing file is invalid input naming it.
    pub async fn read_prefix(&self, url: &str, max: u64) -> Result<(Bytes, u64)> {
        read_url_prefix(url, &self.s3, max).await.map_err(|e| missing_named(url, e))
    }

    /// Bytes `range` of a file (one range request; the range must lie within the file). A missing file is
    /// invalid input naming it.
    pub async fn read_range(&self, url: &str, range: std::ops::Range<u64>) -> Result<Bytes> {
        read_url_range(url, &self.s3, range).await.map_err(|e| missing_named(url, e))
    }

    /// A file's size in bytes. A missing file is invalid input naming it.
    pub async fn size(&self, url: &str) -> Result<u64> {
        size_of_url(url, &self.s3).await.map_err(|e| missing_named(url, e))
    }

    /// How GDAL reads an `s3://` file in place, fetching only the byte ranges a window needs (`/vsis3/` with
    /// the runtime config's endpoint and credentials); `None` for other schemes.
    pub fn remote_raster(&self, url: &str) -> Result<Option<GdalRemote>> {
        Ok(gdal_remote(url, &self.s3)?)
    }

    /// How to open the raster at `url` with GDAL without fetching it whole when that can be avoided: a local
    /// file in place, an `s3://` file by range requests ([`Files::remote_raster`]), anything else (e.g.
    /// `memory://`) read whole.
    pub async fn pixel_input(&self, url: &str) -> Result<PixelInput> {
        if let StoreLocation::Local(path) = StoreLocation::parse(url)? {
            return Ok(PixelInput::Path(path));
        }
        if let Some(remote) = self.remote_raster(url)? {
            return Ok(PixelInput::Remote(remote));
        }
        Ok(PixelInput::Bytes(self.read(url).await?.to_vec()))
    }

    /// Whether the file exists.
    pub async fn exists(&self, url: &str) -> Result<bool> {
        match head_url(url, &self.s3).await {
            Ok(()) => Ok(true),
            Err(e) if e.kind() == StoreErrorKind::NotFound => Ok(false),
            Err(e) => Err(e.into()),
        }
    }

    /// Bytes and objects stored under a prefix (a directory or `s3://bucket/prefix/`); a prefix that does
    /// not exist holds nothing.
    pub async fn prefix_size(&self, url: &str) -> Result<(u64, u64)> {
        match crate::store::prefix_size(url, &self.s3).await {
            Err(e) if e.kind() == StoreErrorKind::NotFound => Ok((0, 0)),
            other => other.with_context(|| format!("listing {url}")),
        }
    }

    /// Write a whole file, replacing it.
    pub async fn write(&self, url: &str, bytes: Vec<u8>) -> Result<()> {
        write_url(url, &self.s3, Bytes::from(bytes)).await.with_context(|| format!("writing {url}"))
    }
}

/// A store error as a service error; a missing file says so by name.
fn missing_named(url: &str, e: crate::store::StoreError) -> Error {
    if e.kind() == StoreErrorKind::NotFound { Error::missing(format!("{url}: not found")) } else { e.into() }
}

/// The last path segment of a path or URL, for messages.
pub fn file_name(url: &str) -> &str {
    url.rsplit(['/', '\\']).next().filter(|s| !s.is_empty()).unwrap_or(url)
}
