//! The worker's answers to the ops listener: readiness, and metrics with the consumer's lag read at scrape
//! time.

use futures::future::BoxFuture;
use plumbline_runtime::Files;
use plumbline_scheduler::bus::Bus;

use super::Worker;
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
