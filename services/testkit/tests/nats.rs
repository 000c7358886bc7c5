//! The JetStream features the distributed services rely on work against the real server the kit starts:
//! KV buckets, a work-queue stream with a durable pull consumer, explicit acks, redelivery after a nak,
//! and persistence across a kill -9 and restart.
#![allow(clippy::unwrap_used)]

use std::time::Duration;

use async_nats::jetstream::{self, AckKind, consumer, kv, stream};
use futures::StreamExt;
use plumbline_testkit::{MIN_NATS_VERSION, NatsServer, nats_server_version};

async fn next_message(consumer: &consumer::PullConsumer) -> jetstream::Message {
    let mut batch = consumer.fetch().max_messages(1).expires(Duration::from_secs(10)).messages().await.unwrap();
    batch.next().await.expect("a message within 10 s").unwrap()
}

#[test]
fn the_server_on_path_is_new_enough() {
    let (major, minor, _) = nats_server_version().unwrap();
    assert!((major, minor) >= MIN_NATS_VERSION);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn kv_and_work_queue_survive_a_server_kill() {
    let mut server = NatsServer::start();
    let client = async_nats::connect(server.url()).await.unwrap();
    let js = jetstream::new(client);

    let bucket =
        js.create_key_value(kv::Config { bucket: "campaigns".into(), history: 1, ..Default::default() }).await.unwrap();
    bucket.put("hh-2024", "running".into()).await.unwrap();

    let queue = js
        .create_stream(stream::Config {
            name: "TILES".into(),
            subjects: vec!["tiles.>".into()],
            retention: stream::RetentionPolicy::WorkQueue,
            storage: stream::StorageType::File,
            ..Default::default()
        })
        .await
        .unwrap();
    let workers = queue
        .create_consumer(consumer::pull::Config {
            durable_name: Some("workers".into()),
            ack_policy: consumer::AckPolicy::Explicit,
            ack_wait: Duration::from_secs(2),
            max_deliver: 3,
            ..Default::default()
        })
        .await
        .unwrap();
    for tile in ["c0_r0", "c1_r0"] {
        js.publish(format!("tiles.hh-2024.{tile}"), tile.into()).await.unwrap().await.unwrap();
    }

    // A nak makes the server hand the same task out again, counting the delivery (order is not promised).
    let first = next_message(&workers).await;
    let naked = first.payload.clone();
    first.ack_with(AckKind::Nak(None)).await.unwrap();
    let mut kept = None;
    loop {
        let m = next_message(&workers).await;
        if m.payload == naked {
            assert_eq!(m.info().unwrap().delivered, 2);
            m.double_ack().await.unwrap();
            break;
        }
        // The other task: leave it unacknowledged; the short ack_wait hands it out again later.
        kept = Some(m.payload.clone());
    }
    let other: &[u8] = if &naked[..] == b"c0_r0" { b"c1_r0" } else { b"c0_r0" };
    assert!(kept.as_deref().is_none_or(|k| k == other));

    // kill -9 and restart on the same port and store: state is still there.
    server.restart();
    let client = async_nats::connect(server.url()).await.unwrap();
    let js = jetstream::new(client);
    let bucket = js.get_key_value("campaigns").await.unwrap();
    assert_eq!(bucket.get("hh-2024").await.unwrap().as_deref(), Some(&b"running"[..]));
    let mut queue = js.get_stream("TILES").await.unwrap();
    assert_eq!(queue.info().await.unwrap().state.messages, 1, "the acked task is gone, the other remains");
    let workers: consumer::PullConsumer = queue.get_consumer("workers").await.unwrap();
    let rest = next_message(&workers).await;
    assert_eq!(&rest.payload[..], other);
    rest.double_ack().await.unwrap();
}
