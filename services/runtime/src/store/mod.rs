//! Object stores opened from URLs (`file://`, `memory://`, `s3://`, plain paths), and byte helpers that name the key on error.
//!
//! A *store URL* names a directory-like root ([`open_store`]); an *object URL* names one object
//! ([`read_url`], [`write_url`]). Plain paths without a scheme are local files or directories.

mod error;
mod location;
mod s3;
mod upload;

use std::sync::Arc;

use bytes::Bytes;
use object_store::memory::InMemory;
use object_store::path::Path;
use object_store::{ObjectStore, ObjectStoreExt, local::LocalFileSystem};

pub use error::{StoreError, StoreErrorKind};
pub use location::StoreLocation;
pub use s3::{DEFAULT_REGION, S3Options};
pub use upload::{PART_SIZE, StreamingUpload};

/// An opened store and the key prefix its URL named; keys for this root go under `prefix`.
#[derive(Debug, Clone)]
pub struct StoreRoot {
    pub store: Arc<dyn ObjectStore>,
    /// Key prefix from the URL's path (`s3://bucket/a/b` → `a/b`); empty for `file://` roots,
    /// whose directory is the store's own root.
    pub prefix: Path,
    /// The URL the root was opened from, for messages.
    pub url: String,
}

impl StoreRoot {
    /// The full key of `relative` (slash-separated, e.g. `tiles/0007/result.json`) under the prefix.
    pub fn key(&self, relative: &str) -> Result<Path, StoreError> {
        let rel = Path::parse(relative).map_err(|e| {
            StoreError::new(StoreErrorKind::Permanent, format!("invalid key `{relative}` under `{}`: {e}", self.url))
        })?;
        Ok(rel.parts().fold(self.prefix.clone(), |key, part| key.join(part)))
    }
}

/// Opens the store a URL names: `file:///abs/dir` or a plain path (a local directory, created if
/// missing), `memory://[prefix]` (a fresh, empty in-memory store) or `s3://bucket[/prefix]`
/// (configured by `s3`, which the other schemes ignore).
pub fn open_store(url: &str, s3: &S3Options) -> Result<StoreRoot, StoreError> {
    let (store, prefix): (Arc<dyn ObjectStore>, Path) = match StoreLocation::parse(url)? {
        StoreLocation::Local(dir) => (Arc::new(open_local_dir(url, &dir)?), Path::default()),
        StoreLocation::Memory { prefix } => (Arc::new(InMemory::new()), prefix),
        StoreLocation::S3 { bucket, prefix } => (Arc::new(s3::build(url, &bucket, s3)?), prefix),
    };
    Ok(StoreRoot { store, prefix, url: url.to_owned() })
}

fn open_local_dir(url: &str, dir: &std::path::Path) -> Result<LocalFileSystem, StoreError> {
    std::fs::create_dir_all(dir).map_err(|e| {
        StoreError::new(StoreErrorKind::Permanent, format!("store URL `{url}`: cannot create directory: {e}"))
    })?;
    LocalFileSystem::new_with_prefix(dir).map_err(|e| StoreError::from_store("open local store", url, e))
}

/// Opens the store holding the one object `url` names, and that object's key. Creates nothing.
fn open_object(url: &str, s3: &S3Options) -> Result<(Arc<dyn ObjectStore>, Path), StoreError> {
    let (store, key): (Arc<dyn ObjectStore>, Path) = match StoreLocation::parse(url)? {
        StoreLocation::Local(file) => (Arc::new(LocalFileSystem::new()), local_key(url, &file)?),
        StoreLocation::Memory { prefix } => (Arc::new(InMemory::new()), prefix),
        StoreLocation::S3 { bucket, prefix } => (Arc::new(s3::build(url, &bucket, s3)?), prefix),
    };
    if key.parts_count() == 0 {
        return Err(location::invalid(url, "names no object (the key is empty)"));
    }
    Ok((store, key))
}

fn local_key(url: &str, file: &std::path::Path) -> Result<Path, StoreError> {
    let absolute = std::path::absolute(file)
        .map_err(|e| location::invalid(url, &format!("cannot make the path absolute: {e}")))?;
    Path::from_absolute_path(lexically_normal(&absolute))
        .map_err(|e| location::invalid(url, &format!("invalid path: {e}")))
}

/// `a/b/../c` → `a/c` and `a/./b` → `a/b` without touching the filesystem (the file may not exist yet).
fn lexically_normal(path: &std::path::Path) -> std::path::PathBuf {
    use std::path::Component;
    let mut out = std::path::PathBuf::new();
    for c in path.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                out.pop();
            }
            other => out.push(other.as_os_str()),
        }
    }
    out
}

/// The bytes and the number of objects stored under a prefix URL (`s3://bucket/agencies/a/`, a local
/// directory), listed page by page: what an agency keeps in the store.
pub async fn prefix_size(url: &str, s3: &S3Options) -> Result<(u64, u64), StoreError> {
    use futures::TryStreamExt as _;
    let root = open_store(url, s3)?;
    let prefix = (!root.prefix.as_ref().is_empty()).then_some(&root.prefix);
    let mut listing = root.store.list(prefix);
    let (mut bytes, mut objects) = (0u64, 0u64);
    while let Some(meta) = listing.try_next().await.map_err(|e| StoreError::from_store("list", url, e))? {
        bytes = bytes.saturating_add(meta.size);
        objects += 1;
    }
    Ok((bytes, objects))
}

/// Checks that the object an object URL names exists, reading only its metadata.
pub async fn head_url(url: &str, s3: &S3Options) -> Result<(), StoreError> {
    let (store, key) = open_object(url, s3)?;
    store.head(&key).await.map_err(|e| StoreError::from_store("head", url, e))?;
    Ok(())
}

/// Reads the whole object an object URL names (`s3://bucket/key`, `file:///abs/file`, `./rel/file`).
pub async fn read_url(url: &str, s3: &S3Options) -> Result<Bytes, StoreError> {
    let (store, key) = open_object(url, s3)?;
    store
        .get(&key)
        .await
        .map_err(|e| StoreError::from_store("get", url, e))?
        .bytes()
        .await
        .map_err(|e| StoreError::from_store("read body of", url, e))
}

/// Reads at most the first `max` bytes of the object an object URL names (one range request), and its
/// total size: for headers (point clouds, images) without fetching whole files.
pub async fn read_url_prefix(url: &str, s3: &S3Options, max: u64) -> Result<(Bytes, u64), StoreError> {
    let (store, key) = open_object(url, s3)?;
    let meta = store.head(&key).await.map_err(|e| StoreError::from_store("head", url, e))?;
    let end = meta.size.min(max);
    if end == 0 {
        return Ok((Bytes::new(), meta.size));
    }
    let bytes = store.get_range(&key, 0..end).await.map_err(|e| StoreError::from_store("read range of", url, e))?;
    Ok((bytes, meta.size))
}

/// Reads bytes `range` of the object an object URL names (one range request; the range must lie within it).
pub async fn read_url_range(url: &str, s3: &S3Options, range: std::ops::Range<u64>) -> Result<Bytes, StoreError> {
    let (store, key) = open_object(url, s3)?;
    store.get_range(&key, range).await.map_err(|e| StoreError::from_store("read range of", url, e))
}

/// The size of the object an object URL names, in bytes (its metadata only).
pub async fn size_of_url(url: &str, s3: &S3Options) -> Result<u64, StoreError> {
    let (store, key) = open_object(url, s3)?;
    Ok(store.head(&key).await.map_err(|e| StoreError::from_store("head", url, e))?.size)
}

/// How GDAL reads an object in place with its own range requests: a GDAL path and the GDAL options (set per
/// thread while the file is open) that carry the store's endpoint and credentials.
#[derive(Clone, Debug, PartialEq)]
pub struct GdalRemote {
    /// `/vsis3/{bucket}/{key}`.
    pub path: String,
    /// `AWS_*` configuration options for GDAL's `/vsis3/` handler.
    pub options: Vec<(String, String)>,
}

/// The [`GdalRemote`] of an `s3://` object URL with these S3 settings; `None` for the other schemes (local
/// files are opened in place, in-memory objects read whole). Nothing is read from the environment: without
/// credentials, requests are unsigned.
pub fn gdal_remote(url: &str, s3: &S3Options) -> Result<Option<GdalRemote>, StoreError> {
    let StoreLocation::S3 { bucket, prefix } = StoreLocation::parse(url)? else {
        return Ok(None);
    };
    if prefix.parts_count() == 0 {
        return Err(location::invalid(url, "names no object (the key is empty)"));
    }
    s3.validate().map_err(|reason| location::invalid(url, &reason))?;
    let mut options = vec![
        ("AWS_REGION".to_owned(), s3.region.clone().unwrap_or_else(|| DEFAULT_REGION.to_owned())),
        ("AWS_VIRTUAL_HOSTING".to_owned(), if s3.virtual_hosted_style { "TRUE" } else { "FALSE" }.to_owned()),
    ];
    if let Some(endpoint) = &s3.endpoint {
        let parsed = url::Url::parse(endpoint).map_err(|e| location::invalid(url, &e.to_string()))?;
        let host = parsed.host_str().unwrap_or_default();
        let host = match parsed.port() {
            Some(port) => format!("{host}:{port}"),
            None => host.to_owned(),
        };
        options.push(("AWS_S3_ENDPOINT".to_owned(), host));
        options.push(("AWS_HTTPS".to_owned(), if parsed.scheme() == "https" { "YES" } else { "NO" }.to_owned()));
    }
    match (&s3.access_key_id, &s3.secret_access_key) {
        (Some(key), Some(secret)) => {
            options.push(("AWS_ACCESS_KEY_ID".to_owned(), key.clone()));
            options.push(("AWS_SECRET_ACCESS_KEY".to_owned(), secret.expose().to_owned()));
        }
        _ => options.push(("AWS_NO_SIGN_REQUEST".to_owned(), "YES".to_owned())),
    }
    Ok(Some(GdalRemote { path: format!("/vsis3/{bucket}/{prefix}"), options }))
}

/// Writes `bytes` as the object an object URL names, replacing it; local parent directories are created.
pub async fn write_url(url: &str, s3: &S3Options, bytes: Bytes) -> Result<(), StoreError> {
    let (store, key) = open_object(url, s3)?;
    store.put(&key, bytes.into()).await.map_err(|e| StoreError::from_store("put", url, e))?;
    Ok(())
}

/// Reads the whole object at `key`; the error names the key.
pub async fn get_bytes(store: &dyn ObjectStore, key: &Path) -> Result<Bytes, StoreError> {
    let result = store.get(key).await.map_err(|e| StoreError::from_store("get", key.as_ref(), e))?;
    result.bytes().await.map_err(|e| StoreError::from_store("read body of", key.as_ref(), e))
}

/// Writes `bytes` at `key`, replacing any object there; the error names the key.
pub async fn put_bytes(store: &dyn ObjectStore, key: &Path, bytes: Bytes) -> Result<(), StoreError> {
    store.put(key, bytes.into()).await.map_err(|e| StoreError::from_store("put", key.as_ref(), e))?;
    Ok(())
}
