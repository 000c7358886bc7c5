//! Answering JetStream messages while long work runs: in-progress acks so the server does not redeliver a
//! message whose work is still going, and acks whose failure is logged rather than fatal.

use std::future::Future;
use std::time::Duration;

use async_nats::jetstream::{self, AckKind};

/// Run `work`, sending an in-progress ack for `message` every `every`.
pub async fn with_heartbeat<T>(message: &jetstream::Message, every: Duration, work: impl Future<Output = T>) -> T {
    tokio::pin!(work);
    let mut ticks = tokio::time::interval_at(tokio::time::Instant::now() + every, every);
    loop {
        tokio::select! {
            out = &mut work => return out,
            _ = ticks.tick() => reply(message, AckKind::Progress).await,
        }
    }
}

/// Send an ack of `kind`, logging a failure (the server redelivers an unacked message anyway).
pub async fn reply(message: &jetstream::Message, kind: AckKind) {
    if let Err(e) = message.ack_with(kind).await {
        tracing::warn!(error = %e, "ack failed");
    }
}
