//! Small SVG plots for the report: line charts, histograms with a standard-normal overlay, and an
//! equal-aspect map. Plain strings, no scripts, no external references.

use std::fmt::Write as _;

use crate::model::{MapLine, MapMark, MarkState, TrackPoint};

/// Plot frame: outer size in pixels and axis labels.
#[derive(Clone, Copy, Debug)]
pub struct Axes<'a> {
    /// Width, px.
    pub width: f64,
    /// Height, px.
    pub height: f64,
    /// Label under the x axis.
    pub x_label: &'a str,
    /// Label beside the y axis.
    pub y_label: &'a str,
}

/// One line of a line chart.
#[derive(Clone, Copy, Debug)]
pub struct Line<'a> {
    /// Legend text.
    pub name: &'a str,
    /// CSS colour.
    pub color: &'a str,
    /// x values.
    pub x: &'a [f64],
    /// y values (non-finite values break the line).
    pub y: &'a [f64],
}

const MARGIN_LEFT: f64 = 64.0;
const MARGIN_RIGHT: f64 = 16.0;
const MARGIN_TOP: f64 = 24.0;
const MARGIN_BOTTOM: f64 = 44.0;

/// Escape text for XML/HTML.
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            _ => out.push(c),
        }
    }
    out
}

/// About `count` round tick values covering [lo, hi] (1, 2 or 5 × 10^k steps).
pub fn nice_ticks(lo: f64, hi: f64, count: usize) -> Vec<f64> {
    if !(lo.is_finite() && hi.is_finite()) || hi <= lo || count == 0 {
        return Vec::new();
    }
    let raw = (hi - lo) / count as f64;
    let magnitude = 10f64.powf(raw.log10().floor());
    // The round step whose tick count comes closest to the wish.
    let ticks = |step: f64| ((hi / step).floor() - (lo / step).ceil() + 1.0).max(0.0);
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * magnitude)
        .min_by(|a, b| (ticks(*a) - count as f64).abs().total_cmp(&(ticks(*b) - count as f64).abs()))
        .unwrap_or(magnitude);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last).map(|k| k as f64 * step).collect()
}

/// Finite range of some values, widened when degenerate; `None` when there is no finite value.
fn range<'a>(values: impl Iterator<Item = &'a f64>) -> Option<(f64, f64)> {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    if lo > hi {
        return None;
    }
    let pad = if hi > lo { 0.0 } else { lo.abs().max(1.0) * 0.05 };
    Some((lo - pad, hi + pad))
}

/// Linear map from data to pixel coordinates of the plot area.
#[derive(Clone, Copy, Debug)]
struct Frame {
    x: (f64, f64),
    y: (f64, f64),
    w: f64,
    h: f64,
}

impl Frame {
    fn px(&self, x: f64) -> f64 {
        MARGIN_LEFT + (x - self.x.0) / (self.x.1 - self.x.0) * self.w
    }
    fn py(&self, y: f64) -> f64 {
        MARGIN_TOP + (self.y.1 - y) / (self.y.1 - self.y.0) * self.h
    }
}

fn open(axes: &Axes<'_>) -> String {
    format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\" \
         font-family=\"sans-serif\" font-size=\"11\">",
        w = axes.width,
        h = axes.height
    )
}

fn frame_and_ticks(s: &mut String, f: &Frame, axes: &Axes<'_>) {
    let _ = write!(
        s,
        "<rect x=\"{MARGIN_LEFT}\" y=\"{MARGIN_TOP}\" width=\"{:.1}\" height=\"{:.1}\" fill=\"none\" stroke=\"#999\"/>",
        f.w, f.h
    );
    for t in nice_ticks(f.x.0, f.x.1, 6) {
        let x = f.px(t);
        let _ = write!(
            s,
            "<line x1=\"{x:.1}\" x2=\"{x:.1}\" y1=\"{:.1}\" y2=\"{:.1}\" stroke=\"#eee\"/>\
             <text x=\"{x:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{}</text>",
            MARGIN_TOP,
            MARGIN_TOP + f.h,
            MARGIN_TOP + f.h + 14.0,
            label(t)
        );
    }
    for t in nice_ticks(f.y.0, f.y.1, 5) {
        let y = f.py(t);
        let _ = write!(
            s,
            "<line x1=\"{MARGIN_LEFT}\" x2=\"{:.1}\" y1=\"{y:.1}\" y2=\"{y:.1}\" stroke=\"#eee\"/>\
             <text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"end\">{}</text>",
            MARGIN_LEFT + f.w,
            MARGIN_LEFT - 6.0,
            y + 4.0,
            label(t)
        );
    }
    let _ = write!(
        s,
        "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{}</text>\
         <text transform=\"translate(14 {:.1}) rotate(-90)\" text-anchor=\"middle\">{}</text>",
        MARGIN_LEFT + f.w / 2.0,
        axes.height - 8.0,
        escape(axes.x_label),
        MARGIN_TOP + f.h / 2.0,
        escape(axes.y_label)
    );
}

fn label(v: f64) -> String {
    let text = format!("{v:.6}");
    let text = text.trim_end_matches('0').trim_end_matches('.');
    if text == "-0" { "0".into() } else { text.into() }
}

fn empty(axes: &Axes<'_>, why: &str) -> String {
    format!(
        "{}<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\" fill=\"#777\">{}</text></svg>",
        open(axes),
        axes.width / 2.0,
        axes.height / 2.0,
        escape(why)
    )
}

/// A line chart of several series sharing axes, with a legend.
pub fn line_chart(axes: &Axes<'_>, lines: &[Line<'_>]) -> String {
    let xr = range(lines.iter().flat_map(|l| l.x.iter()));
    let yr = range(lines.iter().flat_map(|l| l.y.iter()));
    let (Some(x), Some(y)) = (xr, yr) else {
        return empty(axes, "no data");
    };
    let f = Frame { x, y, w: axes.width - MARGIN_LEFT - MARGIN_RIGHT, h: axes.height - MARGIN_TOP - MARGIN_BOTTOM };
    let mut s = open(axes);
    frame_and_ticks(&mut s, &f, axes);
    for (k, line) in lines.iter().enumerate() {
        for run in runs(line) {
            let points: Vec<String> = run.iter().map(|&(x, y)| format!("{:.1},{:.1}", f.px(x), f.py(y))).collect();
            let _ = write!(
                s,
                "<polyline fill=\"none\" stroke=\"{}\" stroke-width=\"1.2\" points=\"{}\"/>",
                escape(line.color),
                points.join(" ")
            );
        }
        let lx = MARGIN_LEFT + 8.0 + 130.0 * k as f64;
        let _ = write!(
            s,
            "<rect x=\"{lx:.1}\" y=\"6\" width=\"12\" height=\"4\" fill=\"{}\"/>\
             <text x=\"{:.1}\" y=\"12\">{}</text>",
            escape(line.color),
            lx + 16.0,
            escape(line.name)
        );
    }
    s.push_str("</svg>");
    s
}

/// Runs of consecutive finite points of a line.
fn runs(line: &Line<'_>) -> Vec<Vec<(f64, f64)>> {
    let mut out = vec![Vec::new()];
    for (&x, &y) in line.x.iter().zip(line.y) {
        if x.is_finite() && y.is_finite() {
            if let Some(r) = out.last_mut() {
                r.push((x, y));
            }
        } else if out.last().is_some_and(|r| !r.is_empty()) {
            out.push(Vec::new());
        }
    }
    out.retain(|r| !r.is_empty());
    out
}

/// A histogram of normalised residuals over [−lim, lim] in `bins` bins (values outside are counted in the
/// outer bins), with the standard normal density scaled to the count for comparison.
pub fn histogram(axes: &Axes<'_>, values: &[f64], bins: usize, lim: f64) -> String {
    let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    if finite.is_empty() || bins == 0 || lim.is_nan() || lim <= 0.0 {
        return empty(axes, "no residuals");
    }
    let width = 2.0 * lim / bins as f64;
    let mut counts = vec![0usize; bins];
    for v in &finite {
        let b = ((v + lim) / width).floor().clamp(0.0, (bins - 1) as f64) as usize;
        counts[b] += 1;
    }
    let normal = |z: f64| finite.len() as f64 * width * (-0.5 * z * z).exp() / (2.0 * std::f64::consts::PI).sqrt();
    let top = counts.iter().copied().max().unwrap_or(0) as f64;
    let f = Frame {
        x: (-lim, lim),
        y: (0.0, top.max(normal(0.0)) * 1.05),
        w: axes.width - MARGIN_LEFT - MARGIN_RIGHT,
        h: axes.height - MARGIN_TOP - MARGIN_BOTTOM,
    };
    let mut s = open(axes);
    frame_and_ticks(&mut s, &f, axes);
    for (b, &c) in counts.iter().enumerate() {
        let x0 = -lim + b as f64 * width;
        let _ = write!(
            s,
            "<rect x=\"{:.1}\" y=\"{:.1}\" width=\"{:.1}\" height=\"{:.1}\" fill=\"#6a9fd4\"/>",
            f.px(x0) + 0.5,
            f.py(c as f64),
            (f.px(x0 + width) - f.px(x0) - 1.0).max(0.5),
            f.py(0.0) - f.py(c as f64)
        );
    }
    let curve: Vec<String> = (0..=100)
        .map(|i| -lim + 2.0 * lim * f64::from(i) / 100.0)
        .map(|z| format!("{:.1},{:.1}", f.px(z), f.py(normal(z))))
        .collect();
    let _ = write!(s, "<polyline fill=\"none\" stroke=\"#c33\" stroke-width=\"1.5\" points=\"{}\"/>", curve.join(" "));
    s.push_str("</svg>");
    s
}

/// Colour of a correction magnitude on a blue→yellow→red scale saturating at `max`.
pub fn ramp(value: f64, max: f64) -> String {
    let t = if max > 0.0 && value.is_finite() { (value / max).clamp(0.0, 1.0) } else { 0.0 };
    let (r, g, b) = if t < 0.5 {
        let u = t * 2.0;
        (40.0 + 215.0 * u, 90.0 + 130.0 * u, 200.0 - 150.0 * u)
    } else {
        let u = (t - 0.5) * 2.0;
        (255.0, 220.0 - 180.0 * u, 50.0 - 20.0 * u)
    };
    format!("#{:02x}{:02x}{:02x}", r as u8, g as u8, b as u8)
}

/// An equal-aspect map: the track coloured by correction, road lines in dark grey (dashed lines dashed),
/// images as circles, poles as squares (filled = used as control).
pub fn map(width: f64, track: &[TrackPoint], images: &[MapMark], poles: &[MapMark], lines: &[MapLine]) -> String {
    let es = track.iter().map(|p| &p.e).chain(images.iter().map(|m| &m.e)).chain(poles.iter().map(|m| &m.e));
    let ns = track.iter().map(|p| &p.n).chain(images.iter().map(|m| &m.n)).chain(poles.iter().map(|m| &m.n));
    let (Some(er), Some(nr)) = (range(es), range(ns)) else {
        return empty(&Axes { width, height: width * 0.6, x_label: "", y_label: "" }, "nothing to map");
    };
    let pad = 10.0;
    let span = (er.1 - er.0).max(nr.1 - nr.0).max(1.0);
    let scale = (width - 2.0 * pad) / span;
    let height = ((nr.1 - nr.0) * scale + 2.0 * pad + 20.0).clamp(120.0, 2.0 * width);
    let px = |e: f64| pad + (e - er.0) * scale;
    let py = |n: f64| height - 20.0 - pad - (n - nr.0) * scale;
    let axes = Axes { width, height, x_label: "", y_label: "" };
    let mut s = open(&axes);
    let max = track.iter().map(|p| p.correction).filter(|c| c.is_finite()).fold(0.0, f64::max);
    for pair in track.windows(2) {
        let _ = write!(
            s,
            "<line x1=\"{:.1}\" y1=\"{:.1}\" x2=\"{:.1}\" y2=\"{:.1}\" stroke=\"{}\" stroke-width=\"3\"/>",
            px(pair[0].e),
            py(pair[0].n),
            px(pair[1].e),
            py(pair[1].n),
            ramp(pair[1].correction, max)
        );
    }
    for l in lines {
        let points: Vec<String> = l.points.iter().map(|p| format!("{:.1},{:.1}", px(p[0]), py(p[1]))).collect();
        let dash = if l.kind == "dashed" { " stroke-dasharray=\"2,2\"" } else { "" };
        let _ = write!(
            s,
            "<polyline points=\"{}\" fill=\"none\" stroke=\"#333\" stroke-width=\"1\"{dash}><title>{}</title></polyline>",
            points.join(" "),
            escape(&l.kind)
        );
    }
    let fill = |state: MarkState, color: &str| match state {
        MarkState::Used => color.to_owned(),
        MarkState::Unused => "white".to_owned(),
        MarkState::Skipped => "#bbb".to_owned(),
    };
    for m in images {
        let _ = write!(
            s,
            "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"3\" fill=\"{}\" stroke=\"#1a6b2f\"><title>{}</title></circle>",
            px(m.e),
            py(m.n),
            fill(m.state, "#2fa34f"),
            escape(&m.id)
        );
    }
    for m in poles {
        let _ = write!(
            s,
            "<rect x=\"{:.1}\" y=\"{:.1}\" width=\"6\" height=\"6\" fill=\"{}\" stroke=\"#5a2d82\"><title>{}</title></rect>",
            px(m.e) - 3.0,
            py(m.n) - 3.0,
            fill(m.state, "#8e44ad"),
            escape(&m.id)
        );
    }
    let _ = write!(
        s,
        "<text x=\"{pad}\" y=\"{:.1}\">correction 0 m <tspan fill=\"{}\">■</tspan> … {max:.2} m <tspan fill=\"{}\">■</tspan>; \
         ○ panorama (filled: registered), □ pole (filled: matched){}; {:.0} m across</text></svg>",
        height - 6.0,
        ramp(0.0, 1.0),
        ramp(1.0, 1.0),
        if lines.is_empty() { "" } else { ", grey: road lines" },
        span
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_and_inside_the_range() {
        assert_eq!(nice_ticks(0.0, 10.0, 5), [0.0, 2.0, 4.0, 6.0, 8.0, 10.0]);
        let t = nice_ticks(-0.37, 0.81, 5);
        assert!(t.iter().all(|v| (-0.37..=0.81).contains(v)));
        assert!((t[1] - t[0] - 0.2).abs() < 1e-12, "{t:?}");
        assert!(nice_ticks(1.0, 1.0, 5).is_empty());
    }

    #[test]
    fn a_line_breaks_at_missing_values() {
        let (x, y) = ([0.0, 1.0, 2.0, 3.0, 4.0], [0.0, 1.0, f64::NAN, 3.0, 4.0]);
        let svg = line_chart(
            &Axes { width: 400.0, height: 200.0, x_label: "t [s]", y_label: "d [m]" },
            &[Line { name: "east", color: "#06c", x: &x, y: &y }],
        );
        assert_eq!(svg.matches("<polyline").count(), 2);
        assert!(svg.contains("t [s]") && svg.ends_with("</svg>"));
    }

    #[test]
    fn histogram_counts_every_value_once_including_the_tails() {
        let values = [-10.0, -0.5, 0.2, 0.4, 10.0, f64::NAN];
        let svg = histogram(&Axes { width: 300.0, height: 200.0, x_label: "", y_label: "" }, &values, 4, 2.0);
        assert_eq!(svg.matches("<rect x=").count(), 1 + 4, "frame + 4 bins");
        assert!(
            histogram(&Axes { width: 300.0, height: 200.0, x_label: "", y_label: "" }, &[], 4, 2.0)
                .contains("no residuals")
        );
    }

    #[test]
    fn text_is_escaped() {
        assert_eq!(escape("<a href=\"x\">&'"), "&lt;a href=&quot;x&quot;&gt;&amp;&#39;");
    }

    #[test]
    fn the_ramp_runs_from_blue_to_red() {
        assert_eq!(ramp(0.0, 1.0), "#285ac8");
        assert_eq!(ramp(1.0, 1.0), "#ff281e");
        assert_eq!(ramp(f64::NAN, 1.0), ramp(0.0, 1.0));
    }
}
