//! The worker's answers to the ops listener (readiness, metrics with the consumer's lag read at scrape
//! time) and the error kinds its metrics count.

use futures::future::BoxFuture;
use plumbline_runtime::Files;
use plumbline_scheduler::bus::{Bus, BusError};

use super::Worker;
use super::attempt::UnreadInputs;
use super::ops::Probe;

impl Probe for Worker {
    fn ready(&self) -> BoxFuture<'_, (bool, bool)> {
        Box::pin(ready(&self.bus, &self.files, self.store_probe.as_deref()))
    }

    fn metrics(&self) -> BoxFuture<'_, String> {
        Box::pin(async {
            match self.consumer.clone().info().await {
                Ok(info) => {
                    self.metrics.set("plumbline_worker_queue_pending", &[], info.num_pending as f64);
                    self.metrics.set("plumbline_worker_queue_ack_pending", &[], info.num_ack_pending as f64);
                }
                Err(e) => tracing::debug!(error = %e, "consumer info for the metrics"),
            }
            self.metrics.render()
        })
    }
}

/// Whether NATS is connected and whether the store answers at `probe` (a missing object is an answer).
pub async fn ready(bus: &Bus, files: &Files, probe: Option<&str>) -> (bool, bool) {
    let nats = bus.js.client().connection_state() == async_nats::connection::State::Connected;
    let store = match probe {
        Some(url) => match files.exists(url).await {
            Ok(_) => true,
            Err(e) => {
                tracing::warn!(error = %format!("{e:#}"), "store not reachable");
                false
            }
        },
        None => true,
    };
    (nats, store)
}

/// The kind of a task's error, for the metrics: `invalid_input`, `unread_inputs`, `store`, `nats`, `other`.
pub fn error_kind(error: &anyhow::Error) -> &'static str {
    if plumbline_runtime::is_invalid(error) {
        "invalid_input"
    } else if error.chain().any(|c| c.is::<UnreadInputs>()) {
        "unread_inputs"
    } else if error.chain().any(|c| c.is::<plumbline_runtime::StoreError>()) {
        "store"
    } else if error.chain().any(|c| c.is::<BusError>()) {
        "nats"
    } else {
        "other"
    }
}

#[cfg(test)]
mod tests {
    use plumbline_geo::tiling::TileId;

    use super::*;

    #[test]
    fn errors_are_counted_by_their_kind_through_context() {
        let unread = UnreadInputs { tile: TileId { col: 1, row: 2 }, count: 3, first: "a.jpg: reset".into() };
        let bus = BusError::Publish { subject: "plumbline.results.x".into(), detail: "timed out".into() };
        let cases = [
            (plumbline_runtime::invalid("panoramas.camera_height_m: not given"), "invalid_input"),
            (anyhow::Error::from(unread).context("tile c1_r2"), "unread_inputs"),
            (anyhow::Error::from(bus).context("publishing"), "nats"),
            (anyhow::anyhow!("tile task: panicked"), "other"),
        ];
        for (error, kind) in cases {
            assert_eq!(error_kind(&error), kind, "{error:#}");
        }
    }
}
