//! One object written in parts as its bytes arrive (a multipart upload), so a file larger than memory can be
//! streamed to any store: parts of [`PART_SIZE`] bytes except the last, at most two in flight.

use object_store::path::Path;
use object_store::{ObjectStore, ObjectStoreExt, WriteMultipart};

use super::StoreError;

/// Size of every part but the last, bytes (the S3 minimum part size).
pub const PART_SIZE: usize = 5 * 1024 * 1024;
/// Parts uploading at once; a write waits while this many are in flight.
const PARTS_IN_FLIGHT: usize = 2;

/// An object being written part by part; nothing is visible under its key until [`finish`](Self::finish).
#[derive(Debug)]
pub struct StreamingUpload {
    writer: WriteMultipart,
    key: Path,
}

impl StreamingUpload {
    /// Start the multipart upload of `key` in `store`.
    pub async fn start(store: &dyn ObjectStore, key: Path) -> Result<Self, StoreError> {
        let upload =
            store.put_multipart(&key).await.map_err(|e| StoreError::from_store("start uploading", key.as_ref(), e))?;
        Ok(Self { writer: WriteMultipart::new_with_chunk_size(upload, PART_SIZE), key })
    }

    /// Add `bytes` at the end (waits while parts are in flight; a full part starts uploading).
    pub async fn write(&mut self, bytes: &[u8]) -> Result<(), StoreError> {
        self.writer
            .wait_for_capacity(PARTS_IN_FLIGHT)
            .await
            .map_err(|e| StoreError::from_store("upload a part of", self.key.as_ref(), e))?;
        self.writer.write(bytes);
        Ok(())
    }

    /// Upload the last part and complete the object.
    pub async fn finish(self) -> Result<(), StoreError> {
        let Self { writer, key } = self;
        writer.finish().await.map_err(|e| StoreError::from_store("complete the upload of", key.as_ref(), e))?;
        Ok(())
    }

    /// Give the upload up, removing the parts uploaded so far.
    pub async fn abort(self) -> Result<(), StoreError> {
        let Self { writer, key } = self;
        writer.abort().await.map_err(|e| StoreError::from_store("abort the upload of", key.as_ref(), e))
    }
}
