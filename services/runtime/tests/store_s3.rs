//! `s3://` stores against a real S3-compatible server (`moto_server`, PyPI `moto[server]`); no mocks.

use bytes::Bytes;
use futures::TryStreamExt;
use object_store::ObjectStoreExt;
use plumbline_runtime::{
    PART_SIZE, S3Options, Secret, StoreErrorKind, StreamingUpload, get_bytes, open_store, put_bytes, read_url,
    write_url,
};
use plumbline_testkit::MotoServer;

fn options(server: &MotoServer) -> S3Options {
    S3Options {
        endpoint: Some(server.endpoint()),
        region: Some("eu-central-1".to_owned()),
        access_key_id: Some("plumbline-test".to_owned()),
        secret_access_key: Some(Secret::new("plumbline-test-secret")),
        allow_http: false, // loopback endpoints need no allow_http
        virtual_hosted_style: false,
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn s3_put_get_list_delete() {
    let server = MotoServer::start();
    server.create_bucket("plumbline");
    let s3 = options(&server);
    let root = open_store("s3://plumbline/campaigns/hh-2024", &s3).expect("open s3 store");
    assert_eq!(root.prefix.as_ref(), "campaigns/hh-2024");

    let a = root.key("tiles/a.json").expect("key");
    let b = root.key("tiles/b.json").expect("key");
    put_bytes(root.store.as_ref(), &a, Bytes::from_static(b"tile a")).await.expect("put a");
    put_bytes(root.store.as_ref(), &b, Bytes::from_static(b"tile b")).await.expect("put b");
    assert_eq!(get_bytes(root.store.as_ref(), &a).await.expect("get a"), Bytes::from_static(b"tile a"));

    let mut listed: Vec<_> =
        root.store.list(Some(&root.prefix)).map_ok(|m| m.location).try_collect().await.expect("list");
    listed.sort();
    assert_eq!(listed, vec![a.clone(), b.clone()]);

    root.store.delete(&a).await.expect("delete a");
    let err = get_bytes(root.store.as_ref(), &a).await.expect_err("deleted object");
    assert_eq!(err.kind(), StoreErrorKind::NotFound);
    assert!(err.to_string().contains("campaigns/hh-2024/tiles/a.json"), "{err}");

    let url = "s3://plumbline/campaigns/hh-2024/tiles/b.json";
    assert_eq!(read_url(url, &s3).await.expect("read by URL"), Bytes::from_static(b"tile b"));
    write_url("s3://plumbline/out/report.json", &s3, Bytes::from_static(b"{}")).await.expect("write by URL");
    assert_eq!(read_url("s3://plumbline/out/report.json", &s3).await.expect("read back"), Bytes::from_static(b"{}"));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn s3_missing_bucket_is_not_retryable() {
    let server = MotoServer::start();
    let root = open_store("s3://no-such-bucket", &options(&server)).expect("open s3 store");
    let key = root.key("x").expect("key");
    let err = get_bytes(root.store.as_ref(), &key).await.expect_err("bucket does not exist");
    assert!(!err.is_retryable(), "{err}");
}

/// A streamed (multipart) upload is invisible until finished; finished, it reads back whole; aborted after a
/// part went up, it leaves neither an object nor an unfinished upload holding parts on the server.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn streaming_uploads_finish_whole_or_abort_without_leftovers() {
    let server = MotoServer::start();
    server.create_bucket("plumbline");
    let root = open_store("s3://plumbline/sim", &options(&server)).expect("open s3 store");
    let store = root.store.as_ref();
    let bytes: Vec<u8> = (0..PART_SIZE + 4096).map(|i| (i % 251) as u8).collect();

    let done = root.key("nav/gnss.csv").expect("key");
    let mut upload = StreamingUpload::start(store, done.clone()).await.expect("start");
    upload.write(&bytes[..PART_SIZE / 2]).await.expect("write");
    upload.write(&bytes[PART_SIZE / 2..]).await.expect("write");
    let before = get_bytes(store, &done).await.expect_err("nothing visible before finish");
    assert_eq!(before.kind(), StoreErrorKind::NotFound);
    upload.finish().await.expect("finish");
    assert_eq!(get_bytes(store, &done).await.expect("read back"), Bytes::from(bytes.clone()));

    let aborted = root.key("nav/imu.bin").expect("key");
    let mut upload = StreamingUpload::start(store, aborted.clone()).await.expect("start");
    upload.write(&bytes).await.expect("write a full part and more");
    upload.write(&[]).await.expect("wait for the part in flight");
    assert!(server.get("/plumbline?uploads").contains("sim/nav/imu.bin"), "the upload is under way");
    upload.abort().await.expect("abort");
    let err = get_bytes(store, &aborted).await.expect_err("no object after abort");
    assert_eq!(err.kind(), StoreErrorKind::NotFound);
    let listed = server.get("/plumbline?uploads");
    assert!(!listed.contains("sim/nav/imu.bin"), "the aborted upload is still listed: {listed}");
}
