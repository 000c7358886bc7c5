//! The adjuster's metric families and its answers to the ops listener (readiness, metrics with the
//! consumer's lag read at scrape time).

use futures::future::BoxFuture;
use plumbline_runtime::ops::{Family, Kind, Probe, ready};

use super::Adjuster;

/// The adjuster's metric families.
pub const ADJUSTER_FAMILIES: [Family; 6] = [
    ("plumbline_adjuster_results_total", Kind::Counter, "Tile results counted, by outcome (done, failed)."),
    (
        "plumbline_adjuster_campaigns_total",
        Kind::Counter,
        "Campaigns finished by the adjuster, by status (done, failed).",
    ),
    ("plumbline_adjuster_adjustment_seconds", Kind::Summary, "Seconds per campaign adjustment (finished or not)."),
    (
        "plumbline_adjuster_retries_total",
        Kind::Counter,
        "Results nakked for a later retry, by error kind (transient, internal, invalid, missing, forbidden).",
    ),
    ("plumbline_adjuster_queue_pending", Kind::Gauge, "Tile results not yet delivered to the adjuster."),
    ("plumbline_adjuster_queue_ack_pending", Kind::Gauge, "Tile results delivered and not yet answered."),
];

impl Probe for Adjuster {
    fn ready(&self) -> BoxFuture<'_, (bool, bool)> {
        Box::pin(async {
            let client = self.bus.js.client();
            ready(&client, &self.files, self.store_probe.as_deref()).await
        })
    }

    fn metrics(&self) -> BoxFuture<'_, String> {
        Box::pin(async {
            if let Ok(info) = self.consumer.clone().info().await {
                self.metrics.set("plumbline_adjuster_queue_pending", &[], info.num_pending as f64);
                self.metrics.set("plumbline_adjuster_queue_ack_pending", &[], info.num_ack_pending as f64);
            }
            self.metrics.render()
        })
    }
}
