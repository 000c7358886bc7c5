//! A file read by range requests as a synchronous `Read + Seek` source, so that decoders written for files
//! (the `las`/`laz` crates) stream an object from S3 or disk holding one window of it, never the whole file.
//! Used on a blocking thread: each window is fetched by blocking on the runtime the reader was made on.

use std::io::{self, Read, Seek, SeekFrom};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use bytes::Bytes;
use tokio::runtime::Handle;

use crate::files::Files;

/// Bytes fetched per range request unless the reader is made with another window: 8 MiB.
pub const DEFAULT_WINDOW: u64 = 8 * 1024 * 1024;

/// A `Read + Seek` view of a file fetched a window at a time (see the module).
#[derive(Debug)]
pub struct RangeReader {
    files: Files,
    url: String,
    handle: Handle,
    size: u64,
    window: u64,
    /// The window held and the offset of its first byte.
    held: Bytes,
    held_at: u64,
    position: u64,
    /// Range requests made and bytes fetched, for the caller's accounting.
    fetched: Arc<Fetched>,
}

/// What a [`RangeReader`] fetched, readable while another thread reads through it.
#[derive(Debug, Default)]
pub struct Fetched {
    requests: AtomicU64,
    bytes: AtomicU64,
}

impl Fetched {
    /// Range requests made.
    pub fn requests(&self) -> u64 {
        self.requests.load(Ordering::Relaxed)
    }

    /// Bytes fetched.
    pub fn bytes(&self) -> u64 {
        self.bytes.load(Ordering::Relaxed)
    }
}

impl RangeReader {
    /// A reader of `url` fetching `window` bytes per request (at least 64 KiB); reads its size now. Call from
    /// async code; read from a blocking thread.
    pub async fn open(files: &Files, url: &str, window: u64) -> crate::Result<Self> {
        let size = files.size(url).await?;
        Ok(Self {
            files: files.clone(),
            url: url.to_owned(),
            handle: Handle::current(),
            size,
            window: window.max(64 * 1024),
            held: Bytes::new(),
            held_at: 0,
            position: 0,
            fetched: Arc::default(),
        })
    }

    /// The file's size, bytes.
    pub fn size(&self) -> u64 {
        self.size
    }

    /// The requests made and bytes fetched so far (shared: it keeps counting after the reader moves on).
    pub fn fetched(&self) -> Arc<Fetched> {
        Arc::clone(&self.fetched)
    }

    /// Bytes held at most: one window.
    pub fn window(&self) -> u64 {
        self.window
    }

    /// Make the window hold the read position.
    fn fill(&mut self) -> io::Result<()> {
        let start = self.position;
        let end = start.saturating_add(self.window).min(self.size);
        let (files, url) = (self.files.clone(), self.url.clone());
        let bytes = self
            .handle
            .block_on(async move { files.read_range(&url, start..end).await })
            .map_err(|e| io::Error::other(format!("{e:#}")))?;
        if (bytes.len() as u64) != end - start {
            let message = format!("{}: asked for bytes {start}–{end}, got {}", self.url, bytes.len());
            return Err(io::Error::new(io::ErrorKind::UnexpectedEof, message));
        }
        self.fetched.requests.fetch_add(1, Ordering::Relaxed);
        self.fetched.bytes.fetch_add(bytes.len() as u64, Ordering::Relaxed);
        (self.held, self.held_at) = (bytes, start);
        Ok(())
    }
}

impl Read for RangeReader {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if buf.is_empty() || self.position >= self.size {
            return Ok(0);
        }
        let inside = self.position >= self.held_at && self.position < self.held_at + self.held.len() as u64;
        if !inside {
            self.fill()?;
        }
        let offset = usize::try_from(self.position - self.held_at).unwrap_or(usize::MAX);
        let available = &self.held[offset.min(self.held.len())..];
        let n = available.len().min(buf.len());
        buf[..n].copy_from_slice(&available[..n]);
        self.position += n as u64;
        Ok(n)
    }
}

impl Seek for RangeReader {
    fn seek(&mut self, to: SeekFrom) -> io::Result<u64> {
        let target = match to {
            SeekFrom::Start(at) => Some(at),
            SeekFrom::End(delta) => self.size.checked_add_signed(delta),
            SeekFrom::Current(delta) => self.position.checked_add_signed(delta),
        };
        let target =
            target.ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "seek before the file's start"))?;
        self.position = target;
        Ok(target)
    }
}
