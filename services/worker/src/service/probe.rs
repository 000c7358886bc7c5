//! The worker's metric families and its answers to the ops listener: readiness, and metrics with the
//! consumer's lag read at scrape time.

use futures::future::BoxFuture;
use plumbline_runtime::ops::{Family, Kind, Probe, ready};

use super::Worker;

/// The worker's metric families.
pub(super) const WORKER_FAMILIES: [Family; 6] = [
    ("plumbline_worker_tasks_in_flight", Kind::Gauge, "Tile tasks being processed."),
    (
        "plumbline_worker_tasks_total",
        Kind::Counter,
        "Tile tasks answered, by outcome (done, resumed, dropped, retried, dead_lettered).",
    ),
    (
        "plumbline_worker_task_errors_total",
        Kind::Counter,
        "Tile task errors by kind (invalid, missing, forbidden, transient, internal) and action (retried, \
         dead_lettered).",
    ),
    (
        "plumbline_worker_stage_seconds",
        Kind::Summary,
        "Seconds per tile and stage (fetch, registration, poles, write, total).",
    ),
    ("plumbline_worker_queue_pending", Kind::Gauge, "Tile tasks not yet delivered to any worker."),
    ("plumbline_worker_queue_ack_pending", Kind::Gauge, "Tile tasks delivered and not yet answered."),
];

impl Probe for Worker {
    fn ready(&self) -> BoxFuture<'_, (bool, bool)> {
        Box::pin(async {
            let client = self.bus.js.client();
            ready(&client, &self.files, self.store_probe.as_deref()).await
        })
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
