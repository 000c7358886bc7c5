//! Prometheus metrics of the long-running roles: a small registry of counters, gauges and summaries (sum
//! and count, no quantiles) with labels, rendered in the text exposition format (0.0.4), and the two
//! helpers every renderer of that format uses ([`header`], [`escape`]). Each role declares its families.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::sync::{Mutex, PoisonError};

/// A metric family's type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Only goes up.
    Counter,
    /// Goes up and down.
    Gauge,
    /// Observations: `_sum` and `_count`.
    Summary,
}

impl Kind {
    fn as_str(self) -> &'static str {
        match self {
            Self::Counter => "counter",
            Self::Gauge => "gauge",
            Self::Summary => "summary",
        }
    }
}

/// A family: name, type, help text.
pub type Family = (&'static str, Kind, &'static str);

/// Labels of one sample, in order.
type Labels = Vec<(&'static str, String)>;

/// A sample's value.
#[derive(Clone, Copy, Debug, Default)]
struct Value {
    value: f64,
    count: u64,
}

/// Counters, gauges and summaries of one process.
#[derive(Debug)]
pub struct Registry {
    families: Vec<Family>,
    samples: Mutex<BTreeMap<(&'static str, Labels), Value>>,
}

impl Registry {
    /// A registry of `families`; samples of other names are ignored.
    pub fn new(families: &[Family]) -> Self {
        Self { families: families.to_vec(), samples: Mutex::new(BTreeMap::new()) }
    }

    fn with(&self, name: &'static str, labels: &[(&'static str, &str)], change: impl FnOnce(&mut Value)) {
        if !self.families.iter().any(|f| f.0 == name) {
            return;
        }
        let key = (name, labels.iter().map(|(k, v)| (*k, (*v).to_owned())).collect());
        change(self.samples.lock().unwrap_or_else(PoisonError::into_inner).entry(key).or_default());
    }

    /// Add `by` to a counter or gauge.
    pub fn add(&self, name: &'static str, labels: &[(&'static str, &str)], by: f64) {
        self.with(name, labels, |v| v.value += by);
    }

    /// Set a gauge.
    pub fn set(&self, name: &'static str, labels: &[(&'static str, &str)], to: f64) {
        self.with(name, labels, |v| v.value = to);
    }

    /// Add one observation to a summary.
    pub fn observe(&self, name: &'static str, labels: &[(&'static str, &str)], value: f64) {
        self.with(name, labels, |v| {
            v.value += value;
            v.count += 1;
        });
    }

    /// The current value of a counter or gauge (summaries: the sum), 0 when never set.
    pub fn value(&self, name: &'static str, labels: &[(&'static str, &str)]) -> f64 {
        let key = (name, labels.iter().map(|(k, v)| (*k, (*v).to_owned())).collect::<Labels>());
        self.samples.lock().unwrap_or_else(PoisonError::into_inner).get(&key).map_or(0.0, |v| v.value)
    }

    /// The exposition text of every family (a family without samples: its header only).
    pub fn render(&self) -> String {
        let samples = self.samples.lock().unwrap_or_else(PoisonError::into_inner);
        let mut out = String::new();
        for &(name, kind, help) in &self.families {
            header(&mut out, name, kind.as_str(), help);
            for ((_, labels), v) in samples.range((name, Vec::new())..).take_while(|((n, _), _)| *n == name) {
                let labels = format_labels(labels);
                if kind == Kind::Summary {
                    let _ = writeln!(out, "{name}_sum{labels} {}", v.value);
                    let _ = writeln!(out, "{name}_count{labels} {}", v.count);
                } else {
                    let _ = writeln!(out, "{name}{labels} {}", v.value);
                }
            }
        }
        out
    }
}

/// Write the `# HELP` and `# TYPE` lines of a metric family.
pub fn header(out: &mut String, name: &str, kind: &str, help: &str) {
    let _ = writeln!(out, "# HELP {name} {help}\n# TYPE {name} {kind}");
}

/// Escape a label value (backslash, double quote, newline).
pub fn escape(label: &str) -> String {
    label.replace('\\', "\\\\").replace('"', "\\\"").replace('\n', "\\n")
}

fn format_labels(labels: &Labels) -> String {
    if labels.is_empty() {
        return String::new();
    }
    let inner: Vec<String> = labels.iter().map(|(k, v)| format!("{k}=\"{}\"", escape(v))).collect();
    format!("{{{}}}", inner.join(","))
}

#[cfg(test)]
mod tests {
    use super::*;

    const FAMILIES: [Family; 3] = [
        ("plumbline_worker_tasks_in_flight", Kind::Gauge, "Tile tasks being processed."),
        ("plumbline_worker_tasks_total", Kind::Counter, "Tile tasks answered, by outcome."),
        ("plumbline_worker_stage_seconds", Kind::Summary, "Seconds per tile and stage."),
    ];

    #[test]
    fn label_values_are_escaped() {
        assert_eq!(escape("a\\b \"c\"\nd"), "a\\\\b \\\"c\\\"\\nd");
    }

    #[test]
    fn counters_gauges_and_summaries_render_with_their_labels() {
        let m = Registry::new(&FAMILIES);
        m.add("plumbline_worker_tasks_total", &[("outcome", "done")], 1.0);
        m.add("plumbline_worker_tasks_total", &[("outcome", "done")], 1.0);
        m.add("plumbline_worker_tasks_total", &[("outcome", "retried")], 1.0);
        m.set("plumbline_worker_tasks_in_flight", &[], 3.0);
        m.add("plumbline_worker_tasks_in_flight", &[], -1.0);
        m.observe("plumbline_worker_stage_seconds", &[("stage", "fetch")], 1.5);
        m.observe("plumbline_worker_stage_seconds", &[("stage", "fetch")], 0.25);
        m.add("not_a_family", &[], 1.0);
        let text = m.render();
        for line in [
            "# TYPE plumbline_worker_tasks_total counter",
            "plumbline_worker_tasks_total{outcome=\"done\"} 2",
            "plumbline_worker_tasks_total{outcome=\"retried\"} 1",
            "plumbline_worker_tasks_in_flight 2",
            "# TYPE plumbline_worker_stage_seconds summary",
            "plumbline_worker_stage_seconds_sum{stage=\"fetch\"} 1.75",
            "plumbline_worker_stage_seconds_count{stage=\"fetch\"} 2",
            "# HELP plumbline_worker_tasks_in_flight Tile tasks being processed.",
        ] {
            assert!(text.lines().any(|l| l == line), "{line} missing from\n{text}");
        }
        assert!(!text.contains("not_a_family"));
        assert_eq!(m.value("plumbline_worker_tasks_total", &[("outcome", "done")]), 2.0);
        // Every sample line belongs to a declared family and parses as `name{labels} number`.
        for l in text.lines().filter(|l| !l.starts_with('#')) {
            let (name, value) = l.rsplit_once(' ').unwrap();
            assert!(value.parse::<f64>().is_ok(), "{l}");
            assert!(FAMILIES.iter().any(|f| name.starts_with(f.0)), "{l}");
        }
    }
}
