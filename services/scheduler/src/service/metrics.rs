//! The scheduler's Prometheus metrics, rendered in the text exposition format (0.0.4) at `/metrics`:
//!
//! - `plumbline_api_requests_total{route, status}` — API requests by route template and status code;
//! - `plumbline_tasks_published_total` — tile tasks the work-queue stream stored;
//! - `plumbline_tasks_duplicate_total` — tile tasks it dropped as duplicates (resubmissions);
//! - `plumbline_campaigns{status}` — campaigns by status, read from the KV bucket at scrape time;
//! - `plumbline_work_queue_messages` — tasks waiting in the work queue, read at scrape time.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, PoisonError};

use plumbline_runtime::ops::metrics::{escape, header};

use crate::messages::CampaignStatus;

/// Counters of one scheduler process.
#[derive(Debug, Default)]
pub struct Metrics {
    requests: Mutex<BTreeMap<(String, u16), u64>>,
    published: AtomicU64,
    duplicates: AtomicU64,
}

impl Metrics {
    /// Count a request answered on `route` with `status`.
    pub fn request(&self, route: &str, status: u16) {
        let mut map = self.requests.lock().unwrap_or_else(PoisonError::into_inner);
        *map.entry((route.to_owned(), status)).or_default() += 1;
    }

    /// Count tasks stored and dropped as duplicates.
    pub fn tasks(&self, published: u64, duplicates: u64) {
        self.published.fetch_add(published, Ordering::Relaxed);
        self.duplicates.fetch_add(duplicates, Ordering::Relaxed);
    }

    /// The exposition text; `campaigns` counts by status and `queued` the work queue, when readable.
    pub fn render(&self, campaigns: Option<&BTreeMap<CampaignStatus, u64>>, queued: Option<u64>) -> String {
        let mut out = String::new();
        header(&mut out, "plumbline_api_requests_total", "counter", "API requests by route and status code.");
        for ((route, status), n) in self.requests.lock().unwrap_or_else(PoisonError::into_inner).iter() {
            let _ =
                writeln!(out, "plumbline_api_requests_total{{route=\"{}\",status=\"{status}\"}} {n}", escape(route));
        }
        header(&mut out, "plumbline_tasks_published_total", "counter", "Tile tasks stored in the work queue.");
        let _ = writeln!(out, "plumbline_tasks_published_total {}", self.published.load(Ordering::Relaxed));
        header(&mut out, "plumbline_tasks_duplicate_total", "counter", "Tile tasks dropped as duplicates.");
        let _ = writeln!(out, "plumbline_tasks_duplicate_total {}", self.duplicates.load(Ordering::Relaxed));
        if let Some(campaigns) = campaigns {
            header(&mut out, "plumbline_campaigns", "gauge", "Campaigns by status.");
            for status in CampaignStatus::ALL {
                let n = campaigns.get(&status).copied().unwrap_or(0);
                let _ = writeln!(out, "plumbline_campaigns{{status=\"{}\"}} {n}", status.as_str());
            }
        }
        if let Some(queued) = queued {
            header(&mut out, "plumbline_work_queue_messages", "gauge", "Tile tasks waiting in the work queue.");
            let _ = writeln!(out, "plumbline_work_queue_messages {queued}");
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_counters_and_gauges() {
        let m = Metrics::default();
        m.request("/v1/campaigns", 201);
        m.request("/v1/campaigns", 201);
        m.request("/v1/campaigns/{id}", 404);
        m.tasks(3, 1);
        let campaigns = BTreeMap::from([(CampaignStatus::Queued, 2)]);
        let text = m.render(Some(&campaigns), Some(7));
        for line in [
            "plumbline_api_requests_total{route=\"/v1/campaigns\",status=\"201\"} 2",
            "plumbline_api_requests_total{route=\"/v1/campaigns/{id}\",status=\"404\"} 1",
            "plumbline_tasks_published_total 3",
            "plumbline_tasks_duplicate_total 1",
            "plumbline_campaigns{status=\"queued\"} 2",
            "plumbline_campaigns{status=\"done\"} 0",
            "plumbline_work_queue_messages 7",
        ] {
            assert!(text.lines().any(|l| l == line), "{line} missing from\n{text}");
        }
        assert!(!m.render(None, None).contains("plumbline_campaigns"));
    }
}
