//! Round trips through `file://`, plain-path and `memory://` stores, and reading/writing single objects by URL.

use bytes::Bytes;
use futures::TryStreamExt;
use plumbline_runtime::{
    S3Options, StoreErrorKind, StoreRoot, get_bytes, head_url, open_store, put_bytes, read_url, write_url,
};

async fn round_trip(root: &StoreRoot) {
    let key = root.key("tiles/0007/result.json").expect("key");
    put_bytes(root.store.as_ref(), &key, Bytes::from_static(b"{\"ok\":true}")).await.expect("put");
    assert_eq!(get_bytes(root.store.as_ref(), &key).await.expect("get"), Bytes::from_static(b"{\"ok\":true}"));
    let listed: Vec<_> =
        root.store.list(Some(&root.prefix)).map_ok(|meta| meta.location).try_collect().await.expect("list");
    assert_eq!(listed, vec![key.clone()]);
    let missing = root.key("tiles/0008/result.json").expect("key");
    let err = get_bytes(root.store.as_ref(), &missing).await.expect_err("missing object");
    assert_eq!(err.kind(), StoreErrorKind::NotFound);
    assert!(err.to_string().contains("tiles/0008/result.json"), "{err}");
}

#[tokio::test]
async fn file_url_round_trip_creates_the_directory() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let dir = tmp.path().join("new/store");
    let url = format!("file://{}", dir.display());
    let root = open_store(&url, &S3Options::default()).expect("open file store");
    assert!(dir.is_dir());
    round_trip(&root).await;
    assert!(dir.join("tiles/0007/result.json").is_file());
}

#[tokio::test]
async fn plain_path_means_file() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let dir = tmp.path().join("plain");
    let root = open_store(dir.to_str().expect("utf-8 path"), &S3Options::default()).expect("open plain path");
    round_trip(&root).await;
    assert!(dir.join("tiles/0007/result.json").is_file());
}

#[tokio::test]
async fn memory_url_round_trip_with_prefix() {
    let root = open_store("memory://campaign/one", &S3Options::default()).expect("open memory store");
    assert_eq!(root.prefix.as_ref(), "campaign/one");
    assert_eq!(root.key("a/b").expect("key").as_ref(), "campaign/one/a/b");
    round_trip(&root).await;
}

#[tokio::test]
async fn objects_by_url() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let file = tmp.path().join("out/trajectory.csv");
    let url = format!("file://{}", file.display());
    write_url(&url, &S3Options::default(), Bytes::from_static(b"t,e,n\n")).await.expect("write by URL");
    assert_eq!(std::fs::read(&file).expect("file written"), b"t,e,n\n");
    let plain = file.to_str().expect("utf-8 path");
    assert_eq!(read_url(plain, &S3Options::default()).await.expect("read by path"), Bytes::from_static(b"t,e,n\n"));
    let missing = format!("{}/missing.csv", tmp.path().display());
    let err = read_url(&missing, &S3Options::default()).await.expect_err("missing file");
    assert_eq!(err.kind(), StoreErrorKind::NotFound);
    assert!(err.to_string().contains("missing.csv"), "{err}");
    head_url(&url, &S3Options::default()).await.expect("head of an existing file");
    let dotted = format!("{}/out/../out/./trajectory.csv", tmp.path().display());
    assert_eq!(read_url(&dotted, &S3Options::default()).await.expect("read through `..`").len(), 6);
    let err = head_url(&missing, &S3Options::default()).await.expect_err("head of a missing file");
    assert_eq!(err.kind(), StoreErrorKind::NotFound);
}

#[tokio::test]
async fn object_url_must_name_an_object() {
    let err = read_url("s3://bucket/", &S3Options::default()).await.expect_err("no key");
    assert_eq!(err.kind(), StoreErrorKind::Config);
    assert!(err.to_string().contains("s3://bucket/"), "{err}");
}

#[test]
fn bad_keys_are_rejected() {
    let root = open_store("memory://", &S3Options::default()).expect("open memory store");
    assert!(root.key("a/../b").is_err());
}
