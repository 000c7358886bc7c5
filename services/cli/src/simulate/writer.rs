//! The two sides of writing a simulated campaign: the [`Sink`] the generator hands files to (a bounded
//! channel, so it cannot run far ahead), and the async [`Writer`] that stores them under `--out`.
//!
//! Whole files are written as they come. Appended files (the `city` preset's per-leg series) grow in place in
//! a local directory; in an object store each is one multipart upload (parts of 5 MiB except the last,
//! `plumbline_runtime::StreamingUpload`) completed when the campaign is done, or aborted if it fails — so
//! memory holds at most a few parts per appended file, whatever the campaign's length.

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

use anyhow::Context as _;
use bytes::Bytes;
use plumbline_runtime::{StoreRoot, StreamingUpload, open_store, put_bytes};
use tokio::sync::mpsc;

use crate::io::Context;

/// What the generator hands the writer: a whole file, or bytes to add at the end of one.
#[derive(Debug)]
pub(super) enum Output {
    /// A whole file (replacing it).
    Put(String, Vec<u8>),
    /// Bytes appended to a file this run creates.
    Append(String, Vec<u8>),
}

/// Where generated files go: path relative to the campaign prefix, bytes; written by the async side.
#[derive(Debug)]
pub(crate) struct Sink {
    tx: mpsc::Sender<Output>,
}

impl Sink {
    /// A sink feeding `tx`.
    pub(super) fn new(tx: mpsc::Sender<Output>) -> Self {
        Self { tx }
    }

    /// Hand a file to the writer (blocks while the queue is full).
    pub(crate) fn put(&self, path: impl Into<String>, bytes: Vec<u8>) -> anyhow::Result<()> {
        self.send(Output::Put(path.into(), bytes))
    }

    /// Hand bytes to append to a file (created empty by the first append of the run).
    pub(crate) fn append(&self, path: impl Into<String>, bytes: Vec<u8>) -> anyhow::Result<()> {
        self.send(Output::Append(path.into(), bytes))
    }

    fn send(&self, output: Output) -> anyhow::Result<()> {
        self.tx.blocking_send(output).map_err(|_| anyhow::anyhow!("the campaign writer stopped"))
    }
}

/// Where the writer puts files.
enum Target {
    /// A local directory; the appended files created so far.
    Local { dir: PathBuf, created: HashSet<PathBuf> },
    /// An object store; one open upload per appended file.
    Store { root: StoreRoot, uploads: HashMap<String, StreamingUpload> },
}

/// Stores the files of one campaign under its prefix.
pub(super) struct Writer<'a> {
    ctx: &'a Context,
    prefix: String,
    target: Target,
    puts: usize,
}

impl<'a> Writer<'a> {
    /// A writer for the campaign under `prefix` (a directory, `file://` or object-store URL ending in `/`).
    pub(super) fn new(ctx: &'a Context, prefix: &str) -> anyhow::Result<Self> {
        let target = match local_dir(prefix) {
            Some(dir) => Target::Local { dir, created: HashSet::new() },
            None => {
                let root = open_store(prefix, ctx.files().s3()).with_context(|| format!("opening {prefix}"))?;
                Target::Store { root, uploads: HashMap::new() }
            }
        };
        Ok(Self { ctx, prefix: prefix.to_owned(), target, puts: 0 })
    }

    /// Store one output.
    pub(super) async fn write(&mut self, output: Output) -> anyhow::Result<()> {
        match (output, &mut self.target) {
            (Output::Put(path, bytes), Target::Local { .. }) => {
                self.ctx.write(&format!("{}{path}", self.prefix), bytes).await?;
                self.puts += 1;
            }
            (Output::Put(path, bytes), Target::Store { root, .. }) => {
                let key = root.key(&path)?;
                put_bytes(&*root.store, &key, Bytes::from(bytes)).await?;
                self.puts += 1;
            }
            (Output::Append(path, bytes), Target::Local { dir, created }) => {
                append(&dir.join(&path), &bytes, created).await?;
            }
            (Output::Append(path, bytes), Target::Store { root, uploads }) => {
                let upload = match uploads.entry(path) {
                    std::collections::hash_map::Entry::Occupied(e) => e.into_mut(),
                    std::collections::hash_map::Entry::Vacant(e) => {
                        let key = root.key(e.key())?;
                        e.insert(StreamingUpload::start(&*root.store, key).await?)
                    }
                };
                upload.write(&bytes).await?;
            }
        }
        Ok(())
    }

    /// Complete the uploads of appended files; returns the number of files written.
    pub(super) async fn finish(self) -> anyhow::Result<usize> {
        match self.target {
            Target::Local { created, .. } => Ok(self.puts + created.len()),
            Target::Store { uploads, .. } => {
                let appended = uploads.len();
                for (_, upload) in uploads {
                    upload.finish().await?;
                }
                Ok(self.puts + appended)
            }
        }
    }

    /// Abort the uploads of appended files (after a failure; what cannot be aborted is only logged).
    pub(super) async fn abort(self) {
        if let Target::Store { uploads, .. } = self.target {
            for (path, upload) in uploads {
                if let Err(e) = upload.abort().await {
                    tracing::warn!("aborting the upload of {path}: {e}");
                }
            }
        }
    }
}

/// The local directory of `--out` (a plain path or `file://` URL); `None` for object stores.
fn local_dir(out: &str) -> Option<PathBuf> {
    match out.split_once("://") {
        None => Some(out.into()),
        Some(("file", path)) => Some(path.into()),
        Some(_) => None,
    }
}

/// Append `bytes` to `path`, creating it (and its directory) on the first call for it.
async fn append(path: &Path, bytes: &[u8], created: &mut HashSet<PathBuf>) -> anyhow::Result<()> {
    use tokio::io::AsyncWriteExt as _;
    let fresh = created.insert(path.to_owned());
    if let Some(dir) = path.parent() {
        tokio::fs::create_dir_all(dir).await.with_context(|| format!("creating {}", dir.display()))?;
    }
    let mut options = tokio::fs::OpenOptions::new();
    options.create(true).write(true);
    if fresh {
        options.truncate(true)
    } else {
        options.append(true)
    };
    let mut file = options.open(path).await.with_context(|| format!("opening {}", path.display()))?;
    file.write_all(bytes).await.with_context(|| format!("appending to {}", path.display()))
}
