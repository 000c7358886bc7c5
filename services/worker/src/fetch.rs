//! Reading a tile's files a few at a time, off the async runtime (with progress forwarded from the blocking
//! work); images are decoded by `plumbline_imaging::decode` within a pixel budget. Every failure is a
//! [`SkippedInput`] naming the file; the caller goes on with the rest.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use bytes::Bytes;
use futures::StreamExt as _;
use plumbline_campaign::progress::Progress;
use plumbline_campaign::{SkipReason, SkippedInput, Stage};
use plumbline_imaging::decode::DecodeError;
use plumbline_runtime::Files;

/// Why the store did not deliver a file: missing (the store says it is not there, or the input is invalid),
/// refused (the store will refuse it again: a bad scheme or URL, permissions), or a read failure a later
/// attempt may get past (network, server, outage; also any error that is not the input's).
pub(crate) fn reason_of_store(e: &plumbline_runtime::Error) -> SkipReason {
    use plumbline_runtime::{ErrorKind, StoreError};
    match e.kind() {
        ErrorKind::Missing => SkipReason::Missing,
        // The store's own refusal (a bad URL or store option) against an input named wrongly.
        ErrorKind::Invalid if e.find::<StoreError>().is_some() => SkipReason::Refused,
        ErrorKind::Invalid => SkipReason::Missing,
        ErrorKind::Forbidden => SkipReason::Refused,
        ErrorKind::Transient | ErrorKind::Internal => SkipReason::Read,
    }
}

/// A skipped item of `stage`.
pub(crate) fn skipped(stage: Stage, item: &str, reason: SkipReason, detail: String) -> SkippedInput {
    SkippedInput::new(stage, item, reason, detail)
}

/// Read `urls` with at most `concurrency` reads in flight, in order. A missing or unreadable file becomes a
/// skipped item of `stage` ([`SkipReason::Missing`] or [`SkipReason::Read`]).
pub(crate) async fn read_all(
    files: &Files,
    urls: &[String],
    concurrency: usize,
    stage: Stage,
) -> Vec<Result<Bytes, SkippedInput>> {
    futures::stream::iter(urls.iter().map(|url| read_one(files, url, stage)))
        .buffered(concurrency.max(1))
        .collect()
        .await
}

/// Read one file; a missing or unreadable one becomes a skipped item of `stage` ([`SkipReason::of_store`]).
pub(crate) async fn read_one(files: &Files, url: &str, stage: Stage) -> Result<Bytes, SkippedInput> {
    files.read(url).await.map_err(|e| skipped(stage, url, reason_of_store(&e), format!("{url}: cannot be read: {e:#}")))
}

/// Run CPU-bound work on rayon's pool (where the workflow crates' own parallel loops run, so that a tile's
/// allocations stay with rayon's threads rather than spreading over tokio's short-lived blocking threads).
pub(crate) async fn on_rayon<T: Send + 'static>(
    work: impl FnOnce() -> T + Send + 'static,
) -> plumbline_runtime::Result<T> {
    let (tx, rx) = futures::channel::oneshot::channel();
    rayon::spawn(move || {
        // The receiver is gone only when the tile was abandoned; nothing to report to then.
        let _ = tx.send(work());
    });
    rx.await.map_err(|_| plumbline_runtime::Error::internal("worker task failed: its rayon job panicked"))
}

/// Run `work` on tokio's blocking pool while forwarding what it counts to `progress` as done items of
/// `stage` (polled four times a second, and once more at the end).
pub(crate) async fn counted<T: Send + 'static>(
    progress: &dyn Progress,
    stage: Stage,
    work: impl FnOnce(&AtomicU64) -> T + Send + 'static,
) -> plumbline_runtime::Result<T> {
    let counter = Arc::new(AtomicU64::new(0));
    let count = Arc::clone(&counter);
    let job = blocking(move || work(&count));
    tokio::pin!(job);
    let mut ticks = tokio::time::interval(Duration::from_millis(250));
    let mut reported = 0;
    let mut forward = || {
        let now = counter.load(Ordering::Relaxed);
        if now > reported {
            progress.advance(stage, now - reported);
            reported = now;
        }
    };
    let out = loop {
        tokio::select! {
            out = &mut job => break out,
            _ = ticks.tick() => forward(),
        }
    };
    forward();
    out
}

/// The skipped item of an image the bounded decoder refused: [`SkipReason::Size`] when its header's size was
/// refused (over the pixel budget, other than expected, empty), [`SkipReason::Decode`] when its bytes were.
/// The detail is the decoder's message, which names the file and the size found against the budget or the
/// size expected.
pub(crate) fn refused(stage: Stage, url: &str, e: &DecodeError) -> SkippedInput {
    let reason = if e.is_size() { SkipReason::Size } else { SkipReason::Decode };
    skipped(stage, url, reason, e.to_string())
}

/// Run CPU-bound work on tokio's blocking pool.
pub(crate) async fn blocking<T: Send + 'static>(
    work: impl FnOnce() -> T + Send + 'static,
) -> plumbline_runtime::Result<T> {
    tokio::task::spawn_blocking(work).await.map_err(plumbline_runtime::Error::from)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sums what it is told per stage.
    #[derive(Default)]
    struct Tally(std::sync::Mutex<Vec<(String, u64)>>);

    impl Progress for Tally {
        fn begin(&self, _: Stage, _: Option<u64>) {}
        fn advance(&self, stage: Stage, n: u64) {
            self.0.lock().unwrap().push((stage.name().to_owned(), n));
        }
        fn skip(&self, _: Stage, _: u64) {}
        fn note(&self, _: Stage, _: &str) {}
        fn end(&self, _: Stage) {}
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn counted_work_reaches_the_progress_while_it_runs_and_in_full() {
        let tally = Tally::default();
        let out = counted(&tally, Stage::Registration, |count| {
            for _ in 0..7 {
                count.fetch_add(1, Ordering::Relaxed);
                std::thread::sleep(Duration::from_millis(120));
            }
            "done"
        })
        .await
        .unwrap();
        assert_eq!(out, "done");
        let calls = tally.0.into_inner().unwrap();
        assert!(calls.iter().all(|(stage, n)| stage == "registration" && *n > 0), "{calls:?}");
        assert_eq!(calls.iter().map(|(_, n)| n).sum::<u64>(), 7);
        // 840 ms of work polled every 250 ms: reported along the way, not only at the end.
        assert!(calls.len() >= 3, "{calls:?}");
    }

    /// The names are the tile output's JSON (`skipped[].reason`): pinned here so a rename is deliberate, and
    /// every name reads back to its reason, so the retry decision sees what the readers wrote.
    #[test]
    fn skip_reasons_keep_their_names_and_read_back() {
        use SkipReason::*;
        let worker = [Missing, Read, Refused, Decode, Size, Url, Time, Frame, Camera, Open, Outside];
        let names: Vec<String> = worker.iter().map(|r| r.name().into_owned()).collect();
        let expected =
            ["missing", "read", "refused", "decode", "size", "url", "time", "frame", "camera", "open", "outside"];
        assert_eq!(names, expected);
        for r in &worker {
            assert_eq!(r.name().parse::<SkipReason>().as_ref(), Ok(r));
        }
        let retryable: Vec<_> = worker.into_iter().filter(SkipReason::retryable).collect();
        assert_eq!(retryable, [Read]);
    }

    #[tokio::test]
    async fn a_missing_file_is_skipped_as_missing_not_as_unread() {
        let dir = tempfile::tempdir().unwrap();
        let url = format!("{}/absent.jpg", dir.path().display());
        let s = read_one(&Files::default(), &url, Stage::Registration).await.unwrap_err();
        assert_eq!((s.stage.name(), s.item.as_str()), ("registration", url.as_str()));
        assert_eq!(s.reason, SkipReason::Missing);
        assert!(!SkipReason::Missing.retryable());
    }

    #[test]
    fn a_refused_image_is_skipped_for_its_size_or_for_its_bytes_naming_the_file() {
        use plumbline_imaging::decode::{Bounds, PANORAMA_PIXELS, header};
        let budget = Bounds::budget(PANORAMA_PIXELS);
        let forged = plumbline_testkit::images::png_claiming(20_000, 20_000);
        let e = header("dir/p7.png", &forged, &budget).unwrap_err();
        let s = refused(Stage::Registration, "dir/p7.png", &e);
        assert_eq!((s.stage.name(), s.item.as_str()), ("registration", "dir/p7.png"));
        assert_eq!(s.reason, SkipReason::Size);
        assert!(s.detail.starts_with("dir/p7.png: 20000 × 20000 px") && s.detail.contains("budget"), "{}", s.detail);
        let e = header("dir/broken.jpg", b"not an image", &budget).unwrap_err();
        let s = refused(Stage::Registration, "dir/broken.jpg", &e);
        assert_eq!(s.reason, SkipReason::Decode);
        assert!(s.detail.starts_with("dir/broken.jpg: "), "{}", s.detail);
    }
}
