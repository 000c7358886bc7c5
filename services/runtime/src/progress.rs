//! Progress a person can follow: bars with rate and ETA on a terminal, throttled log lines otherwise,
//! JSON lines for machines, or nothing. All implement [`plumbline_campaign::progress::Progress`].

use std::collections::HashMap;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle as BarStyle};
use plumbline_campaign::progress::{NoProgress, Progress, Stage};

/// Shortest interval between two log or JSON lines of one stage (its end is always reported).
const LINE_INTERVAL: Duration = Duration::from_secs(2);

/// How progress is shown.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProgressStyle {
    /// Bars on the terminal (stderr).
    Bars,
    /// `tracing` info lines, at most one per stage every two seconds.
    Lines,
    /// One JSON object per line on stderr.
    Json,
    /// Nothing.
    Quiet,
}

impl ProgressStyle {
    /// The style for the command-line flags and whether stderr is a terminal.
    pub fn choose(quiet: bool, json: bool, stderr_is_terminal: bool) -> Self {
        match (quiet, json, stderr_is_terminal) {
            (true, _, _) => Self::Quiet,
            (false, true, _) => Self::Json,
            (false, false, true) => Self::Bars,
            (false, false, false) => Self::Lines,
        }
    }
}

/// A reporter of the given style.
pub fn reporter(style: ProgressStyle) -> Arc<dyn Progress> {
    match style {
        ProgressStyle::Bars => Arc::new(Bars::new()),
        ProgressStyle::Lines => Arc::new(Throttled::new(Sink::Log)),
        ProgressStyle::Json => Arc::new(Throttled::new(Sink::Json)),
        ProgressStyle::Quiet => Arc::new(NoProgress),
    }
}

/// Counts of one stage and the rate/ETA they imply.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StageCount {
    /// Items done.
    pub done: u64,
    /// Items skipped.
    pub skipped: u64,
    /// Items in all, when known.
    pub total: Option<u64>,
}

impl StageCount {
    /// Items handled (done or skipped) per second after `elapsed`.
    pub fn rate(&self, elapsed: Duration) -> Option<f64> {
        let secs = elapsed.as_secs_f64();
        (secs > 0.0 && self.done + self.skipped > 0).then(|| (self.done + self.skipped) as f64 / secs)
    }

    /// Seconds left at the rate so far, when the total is known and some work is done.
    pub fn eta(&self, elapsed: Duration) -> Option<f64> {
        let left = self.total?.saturating_sub(self.done + self.skipped);
        self.rate(elapsed).map(|r| left as f64 / r)
    }

    /// `12/40 (30 %), 2 skipped, 1.5/s, ETA 19 s`.
    pub fn describe(&self, elapsed: Duration) -> String {
        let handled = self.done + self.skipped;
        let mut s = match self.total {
            Some(t) if t > 0 => format!("{handled}/{t} ({:.0} %)", 100.0 * handled as f64 / t as f64),
            Some(t) => format!("{handled}/{t}"),
            None => format!("{handled}"),
        };
        if self.skipped > 0 {
            s.push_str(&format!(", {} skipped", self.skipped));
        }
        if let Some(r) = self.rate(elapsed) {
            s.push_str(&format!(", {r:.2}/s"));
        }
        if let Some(eta) = self.eta(elapsed).filter(|_| Some(handled) != self.total) {
            s.push_str(&format!(", ETA {}", clock(eta)));
        }
        s
    }
}

/// `45 s`, `3 min 20 s`, `2 h 05 min`.
fn clock(seconds: f64) -> String {
    let s = seconds.max(0.0).round() as u64;
    match s {
        0..60 => format!("{s} s"),
        60..3600 => format!("{} min {:02} s", s / 60, s % 60),
        _ => format!("{} h {:02} min", s / 3600, (s % 3600) / 60),
    }
}

/// Where throttled lines go.
#[derive(Clone, Copy, Debug)]
enum Sink {
    Log,
    Json,
}

#[derive(Debug)]
struct StageState {
    count: StageCount,
    start: Instant,
    last_line: Option<Instant>,
}

/// Log or JSON lines, at most one per stage every [`LINE_INTERVAL`].
#[derive(Debug)]
struct Throttled {
    sink: Sink,
    stages: Mutex<HashMap<String, StageState>>,
}

impl Throttled {
    fn new(sink: Sink) -> Self {
        Self { sink, stages: Mutex::new(HashMap::new()) }
    }

    fn update(&self, stage: &str, change: impl FnOnce(&mut StageCount), event: &str, force: bool) {
        let mut stages = self.stages.lock().unwrap_or_else(PoisonError::into_inner);
        let now = Instant::now();
        let state = stages.entry(stage.to_owned()).or_insert_with(|| StageState {
            count: StageCount { done: 0, skipped: 0, total: None },
            start: now,
            last_line: None,
        });
        change(&mut state.count);
        if force || state.last_line.is_none_or(|t| now.duration_since(t) >= LINE_INTERVAL) {
            state.last_line = Some(now);
            self.emit(stage, event, &state.count, now.duration_since(state.start), None);
        }
    }

    fn emit(&self, stage: &str, event: &str, count: &StageCount, elapsed: Duration, note: Option<&str>) {
        match self.sink {
            Sink::Log => match note {
                Some(text) => tracing::info!(target: "plumbline::progress", "{stage}: {text}"),
                None => tracing::info!(target: "plumbline::progress", "{stage} {event}: {}", count.describe(elapsed)),
            },
            Sink::Json => {
                let line = serde_json::json!({
                    "stage": stage,
                    "event": event,
                    "done": count.done,
                    "skipped": count.skipped,
                    "total": count.total,
                    "elapsed_s": elapsed.as_secs_f64(),
                    "rate_per_s": count.rate(elapsed),
                    "eta_s": count.eta(elapsed),
                    "note": note,
                });
                eprintln!("{line}");
            }
        }
    }
}

impl Progress for Throttled {
    fn begin(&self, stage: Stage, total: Option<u64>) {
        let stage = stage.name();
        self.stages.lock().unwrap_or_else(PoisonError::into_inner).remove(stage);
        self.update(stage, |c| c.total = total, "begin", true);
    }
    fn advance(&self, stage: Stage, n: u64) {
        let stage = stage.name();
        self.update(stage, |c| c.done += n, "progress", false);
    }
    fn skip(&self, stage: Stage, n: u64) {
        let stage = stage.name();
        self.update(stage, |c| c.skipped += n, "progress", false);
    }
    fn note(&self, stage: Stage, text: &str) {
        let stage = stage.name();
        let stages = self.stages.lock().unwrap_or_else(PoisonError::into_inner);
        let (count, elapsed) = stages
            .get(stage)
            .map(|s| (s.count, s.start.elapsed()))
            .unwrap_or((StageCount { done: 0, skipped: 0, total: None }, Duration::ZERO));
        drop(stages);
        self.emit(stage, "note", &count, elapsed, Some(text));
    }
    fn end(&self, stage: Stage) {
        let stage = stage.name();
        self.update(stage, |_| {}, "end", true);
    }
}

/// indicatif bars on stderr, one per stage.
#[derive(Debug)]
struct Bars {
    multi: MultiProgress,
    bars: Mutex<HashMap<String, ProgressBar>>,
}

impl Bars {
    fn new() -> Self {
        Self { multi: MultiProgress::with_draw_target(ProgressDrawTarget::stderr()), bars: Mutex::new(HashMap::new()) }
    }

    fn with(&self, stage: &str, f: impl FnOnce(&ProgressBar)) {
        let mut bars = self.bars.lock().unwrap_or_else(PoisonError::into_inner);
        let bar = bars.entry(stage.to_owned()).or_insert_with(|| self.make(stage, None));
        f(bar);
    }

    fn make(&self, stage: &str, total: Option<u64>) -> ProgressBar {
        let bar = match total {
            Some(t) => ProgressBar::new(t),
            None => ProgressBar::new_spinner(),
        };
        let template = match total {
            Some(_) => "{prefix:>14.bold} [{bar:32.cyan/blue}] {pos}/{len} {per_sec} ETA {eta} {msg}",
            None => "{prefix:>14.bold} {spinner} {pos} {per_sec} {elapsed} {msg}",
        };
        if let Ok(style) = BarStyle::with_template(template) {
            bar.set_style(style.progress_chars("=> "));
        }
        bar.set_prefix(stage.to_owned());
        bar.enable_steady_tick(Duration::from_millis(200));
        self.multi.add(bar)
    }
}

impl Progress for Bars {
    fn begin(&self, stage: Stage, total: Option<u64>) {
        let bar = self.make(stage.name(), total);
        if let Some(old) = self.bars.lock().unwrap_or_else(PoisonError::into_inner).insert(stage.name().to_owned(), bar)
        {
            old.finish_and_clear();
        }
    }
    fn advance(&self, stage: Stage, n: u64) {
        self.with(stage.name(), |b| b.inc(n));
    }
    fn skip(&self, stage: Stage, n: u64) {
        self.with(stage.name(), |b| b.inc(n));
    }
    fn note(&self, stage: Stage, text: &str) {
        let text = text.to_owned();
        self.with(stage.name(), |b| b.set_message(text));
    }
    fn end(&self, stage: Stage) {
        self.with(stage.name(), ProgressBar::finish);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rate_and_eta_follow_the_items_handled() {
        let c = StageCount { done: 10, skipped: 2, total: Some(48) };
        let elapsed = Duration::from_secs(6);
        assert_eq!(c.rate(elapsed), Some(2.0));
        assert_eq!(c.eta(elapsed), Some(18.0));
        assert_eq!(c.describe(elapsed), "12/48 (25 %), 2 skipped, 2.00/s, ETA 18 s");
        let unknown = StageCount { done: 3, skipped: 0, total: None };
        assert_eq!(unknown.eta(elapsed), None);
        assert_eq!(unknown.describe(Duration::ZERO), "3");
        let finished = StageCount { done: 48, skipped: 0, total: Some(48) };
        assert!(!finished.describe(elapsed).contains("ETA"));
    }

    #[test]
    fn clocks_read_naturally() {
        assert_eq!(clock(44.6), "45 s");
        assert_eq!(clock(200.0), "3 min 20 s");
        assert_eq!(clock(7_500.0), "2 h 05 min");
        assert_eq!(clock(-3.0), "0 s");
    }

    #[test]
    fn the_style_follows_flags_then_the_terminal() {
        assert_eq!(ProgressStyle::choose(true, true, true), ProgressStyle::Quiet);
        assert_eq!(ProgressStyle::choose(false, true, true), ProgressStyle::Json);
        assert_eq!(ProgressStyle::choose(false, false, true), ProgressStyle::Bars);
        assert_eq!(ProgressStyle::choose(false, false, false), ProgressStyle::Lines);
    }

    #[test]
    fn throttled_reporters_count_from_many_threads() {
        let p = Throttled::new(Sink::Log);
        p.begin(Stage::Tiles, Some(400));
        std::thread::scope(|s| {
            for _ in 0..4 {
                s.spawn(|| {
                    for _ in 0..100 {
                        p.advance(Stage::Tiles, 1);
                    }
                });
            }
        });
        p.skip(Stage::Tiles, 3);
        p.end(Stage::Tiles);
        let stages = p.stages.lock().unwrap();
        assert_eq!(stages["tiles"].count, StageCount { done: 400, skipped: 3, total: Some(400) });
    }
}
