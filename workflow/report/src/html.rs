//! `report.html`: one self-contained page (inline CSS and SVG, no script, no network) showing a [`Report`].

use std::fmt::Write as _;

use plumbline_geo::metrics::Stats;

use crate::model::{Figures, Report};
use crate::svg::{self, Axes, Line, escape};

/// Rows of the skipped-items list shown in full before it is cut (the counts by reason are always complete).
const SKIPPED_LISTED: usize = 200;
/// Rows of rejected observations and flagged epochs shown in full.
const EVENTS_LISTED: usize = 500;

const STYLE: &str = "body{font-family:sans-serif;margin:24px;max-width:1100px;color:#222}\
h1{font-size:22px}h2{font-size:17px;margin-top:28px;border-bottom:1px solid #ddd}\
table{border-collapse:collapse;margin:8px 0}td,th{padding:3px 9px;border-bottom:1px solid #eee;text-align:right}\
th:first-child,td:first-child{text-align:left}.cards{display:flex;flex-wrap:wrap;gap:10px}\
.card{border:1px solid #ddd;border-radius:6px;padding:8px 12px;min-width:120px}\
.card b{display:block;font-size:18px}.muted{color:#777}.good{color:#1a7f37}.bad{color:#b42318}";

/// The page for `report`.
pub fn render(report: &Report) -> String {
    let mut s = String::new();
    let c = &report.campaign;
    let _ = write!(
        s,
        "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>plumbline report — {}</title>\
         <style>{STYLE}</style></head><body><h1>{} <span class=\"muted\">({}, EPSG:{})</span></h1>\
         <p class=\"muted\">Written by {}.</p>",
        escape(&c.id),
        escape(&c.name),
        escape(&c.id),
        c.crs,
        escape(&c.generated_by)
    );
    warnings(&mut s, report);
    summary(&mut s, report);
    accuracy(&mut s, report);
    plots(&mut s, report);
    stages_and_tiles(&mut s, report);
    height_biases(&mut s, report);
    road_lines(&mut s, report);
    skipped(&mut s, report);
    events(&mut s, report);
    s.push_str("</body></html>\n");
    s
}

/// Named inputs that gave no control, first on the page.
fn warnings(s: &mut String, r: &Report) {
    if r.warnings.is_empty() {
        return;
    }
    s.push_str("<h2 class=\"bad\">Inputs that gave no control</h2><ul>");
    for w in &r.warnings {
        let _ = write!(
            s,
            "<li class=\"bad\"><b>{}</b> <code>{}</code>: {}</li>",
            escape(&w.input),
            escape(&w.location),
            escape(&w.message)
        );
    }
    s.push_str("</ul>");
}

fn summary(s: &mut String, r: &Report) {
    let m = &r.summary;
    let share =
        if m.images > 0 { format!("{:.0} %", 100.0 * m.images_matched as f64 / m.images as f64) } else { "–".into() };
    let cards = [
        ("epochs", m.epochs.to_string()),
        ("duration", format!("{:.0} s", m.duration_s)),
        ("length", format!("{:.2} km", m.length_m / 1000.0)),
        ("panoramas registered", format!("{} / {} ({share})", m.images_matched, m.images)),
        ("tie points", m.ties.to_string()),
        ("pole updates", m.pole_updates.to_string()),
        ("GNSS positions", m.gnss.to_string()),
        ("largest correction", format!("{:.3} m", m.max_correction_m)),
        ("σ0 a posteriori", format!("{:.2}", m.sigma0)),
        ("rejected observations", rejected_card(r)),
        ("flagged epochs", r.flags.len().to_string()),
        ("skipped items", r.skipped.len().to_string()),
    ];
    s.push_str("<h2>Summary</h2><div class=\"cards\">");
    for (name, value) in cards {
        let _ = write!(s, "<div class=\"card\"><span class=\"muted\">{name}</span><b>{}</b></div>", escape(&value));
    }
    s.push_str("</div>");
}

/// Rejections by the test, and the tie points they left undetermined.
fn rejected_card(r: &Report) -> String {
    let tested = r.rejected_by_test();
    match r.rejected.len() - tested {
        0 => tested.to_string(),
        n => format!("{tested} (+{n} tie points left undetermined)"),
    }
}

fn stats_row(s: &mut String, what: &str, st: &Stats) {
    let _ = write!(
        s,
        "<td>{what}</td><td>{:.3}</td><td>{:.3}</td><td>{:.3}</td><td>{:.3}</td><td>{:.3}</td>",
        st.median, st.p95, st.p99, st.max, st.rms
    );
}

fn accuracy(s: &mut String, r: &Report) {
    let Some(a) = &r.accuracy else {
        s.push_str("<h2>Accuracy</h2><p class=\"muted\">No reference trajectory was given.</p>");
        return;
    };
    let _ = write!(
        s,
        "<h2>Accuracy against the reference</h2><p class=\"muted\">Reference: {}. Absolute differences in metres \
         (table form of Meyer et al. 2023).</p><table><tr><th>trajectory</th><th>difference</th><th>median</th>\
         <th>95 %</th><th>99 %</th><th>max</th><th>RMS</th></tr>",
        escape(&a.reference)
    );
    for (name, f) in [("DG (before)", &a.before), ("corrected (after)", &a.after)] {
        for (what, st) in [("along-track", &f.along), ("cross-track", &f.cross), ("height", &f.height)] {
            let _ = write!(s, "<tr><td>{name}</td>");
            stats_row(s, what, st);
            s.push_str("</tr>");
        }
    }
    s.push_str("</table>");
    let rmse = |f: &Figures| format!("2D {:.3} m, 3D {:.3} m", f.rmse_2d, f.rmse_3d);
    let better = a.after.rmse_2d <= a.before.rmse_2d;
    let _ = write!(
        s,
        "<p>RMSE before: {}; after: <span class=\"{}\">{}</span>.</p>",
        rmse(&a.before),
        if better { "good" } else { "bad" },
        rmse(&a.after)
    );
}

fn plots(s: &mut String, r: &Report) {
    let wide = |y_label| Axes { width: 1000.0, height: 260.0, x_label: "time [s]", y_label };
    let c = &r.correction;
    s.push_str("<h2>Correction along the trajectory</h2>");
    s.push_str(&svg::line_chart(
        &wide("correction [m]"),
        &[
            Line { name: "east", color: "#1f77b4", x: &c.time, y: &c.east },
            Line { name: "north", color: "#2ca02c", x: &c.time, y: &c.north },
            Line { name: "up", color: "#ff7f0e", x: &c.time, y: &c.up },
            Line { name: "σ horizontal", color: "#999", x: &c.time, y: &c.sigma_horizontal },
        ],
    ));
    if let Some(x) = &r.cross_track {
        s.push_str("<h2>Cross-track difference to the reference</h2>");
        s.push_str(&svg::line_chart(
            &wide("cross-track [m]"),
            &[
                Line { name: "DG (before)", color: "#d62728", x: &x.time, y: &x.before },
                Line { name: "corrected (after)", color: "#1f77b4", x: &x.time, y: &x.after },
            ],
        ));
    }
    s.push_str("<h2>Map</h2>");
    s.push_str(&svg::map(1000.0, &r.map.track, &r.map.images, &r.map.poles, &r.map.lines));
    if !r.residuals.is_empty() {
        s.push_str("<h2>Normalised residuals</h2><p class=\"muted\">Residual / σ per component; red: N(0, 1).</p>");
    }
    for res in &r.residuals {
        let label = format!("{} residual / σ ({} values)", res.kind, res.normalised.len());
        let axes = Axes { width: 480.0, height: 240.0, x_label: &label, y_label: "count" };
        s.push_str(&svg::histogram(&axes, &res.normalised, 40, 5.0));
    }
}

fn stages_and_tiles(s: &mut String, r: &Report) {
    if !r.stages.is_empty() {
        s.push_str(
            "<h2>Stages</h2><table><tr><th>stage</th><th>done</th><th>of</th><th>skipped</th><th>time [s]</th></tr>",
        );
        for st in &r.stages {
            let _ = write!(
                s,
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.1}</td></tr>",
                escape(&st.name),
                st.done,
                st.total,
                st.skipped,
                st.seconds
            );
        }
        s.push_str("</table>");
    }
    if !r.tiles.is_empty() {
        s.push_str(
            "<h2>Tiles</h2><table><tr><th>tile</th><th>panoramas</th><th>registered</th><th>tie points</th>\
             <th>pole updates</th><th>skipped</th></tr>",
        );
        for t in &r.tiles {
            let _ = write!(
                s,
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
                escape(&t.tile),
                t.images,
                t.matched,
                t.ties,
                t.poles,
                t.skipped
            );
        }
        s.push_str("</table>");
    }
}

/// One row per aerial frame set: its frames, bias ± σ (prior σ) and points.
fn height_biases(s: &mut String, r: &Report) {
    if r.height_biases.is_empty() {
        return;
    }
    s.push_str(
        "<h2>Aerial height biases</h2><p class=\"muted\">One common height bias per set of aerial frames the \
         points were triangulated from (aerial height − adjusted height), metres.</p><table><tr><th>frame set</th>\
         <th>bias [m]</th><th>σ [m]</th><th>prior σ [m]</th><th>points</th></tr>",
    );
    for b in &r.height_biases {
        let _ = write!(
            s,
            "<tr><td>{}</td><td>{:+.3}</td><td>{:.3}</td><td>{:.3}</td><td>{}</td></tr>",
            escape(&b.frames.join(" + ")),
            b.bias_m,
            b.sigma_m,
            b.prior_sigma_m,
            b.points
        );
    }
    s.push_str("</table>");
}

/// One row per kind of road line: count, length, median vertex σ.
fn road_lines(s: &mut String, r: &Report) {
    if r.road_lines.is_empty() {
        return;
    }
    s.push_str(
        "<h2>Road lines</h2><p class=\"muted\">Road markings extracted from the panoramas' ortho-images and placed \
         with the corrected trajectory (layer <code>road_lines</code> of observations.gpkg; the DG placement is \
         <code>road_lines_dg</code>), drawn in grey on the map.</p>",
    );
    if let Some(p) = &r.road_line_panoramas {
        let _ = write!(
            s,
            "<p>Strokes from {} panorama(s); skipped: {} registered panorama(s) whose ortho patch showed no paint \
             the extraction kept (none in view, hidden, or no patch), {} whose strokes could not be placed.</p>",
            p.with_strokes, p.without_strokes, p.unplaced
        );
    }
    s.push_str("<table><tr><th>kind</th><th>lines</th><th>length [m]</th><th>median vertex σ [m]</th></tr>");
    for k in &r.road_lines {
        let _ = write!(
            s,
            "<tr><td>{}</td><td>{}</td><td>{:.1}</td><td>{:.3}</td></tr>",
            escape(&k.kind),
            k.lines,
            k.length_m,
            k.median_sigma_m
        );
    }
    s.push_str("</table>");
}

fn skipped(s: &mut String, r: &Report) {
    s.push_str("<h2>Skipped inputs</h2>");
    if r.skipped.is_empty() {
        s.push_str("<p>Nothing was skipped.</p>");
        return;
    }
    s.push_str("<table><tr><th>stage</th><th>reason</th><th>count</th></tr>");
    for (stage, reason, n) in r.skipped_by_reason() {
        let _ = write!(s, "<tr><td>{}</td><td>{}</td><td>{n}</td></tr>", escape(stage.name()), escape(&reason.name()));
    }
    s.push_str("</table><table><tr><th>item</th><th>stage</th><th>why</th></tr>");
    for item in r.skipped.iter().take(SKIPPED_LISTED) {
        let _ = write!(
            s,
            "<tr><td>{}</td><td>{}</td><td style=\"text-align:left\">{}</td></tr>",
            escape(&item.item),
            escape(item.stage.name()),
            escape(&item.detail)
        );
    }
    s.push_str("</table>");
    if r.skipped.len() > SKIPPED_LISTED {
        let _ = write!(s, "<p class=\"muted\">… and {} more in report.json.</p>", r.skipped.len() - SKIPPED_LISTED);
    }
}

fn events(s: &mut String, r: &Report) {
    if !r.rejected.is_empty() {
        s.push_str(
            "<h2>Rejected observations (data snooping)</h2><table><tr><th>kind</th><th>id</th><th>time [s]</th>\
             <th>w-test</th><th>left undetermined by</th></tr>",
        );
        for o in r.rejected.iter().take(EVENTS_LISTED) {
            let _ = write!(
                s,
                "<tr><td>{}</td><td>{}</td><td>{:.3}</td><td>{:.2}</td><td>{}</td></tr>",
                escape(&o.kind),
                escape(&o.id),
                o.time,
                o.w_test,
                escape(o.follows.as_deref().unwrap_or(""))
            );
        }
        s.push_str("</table>");
    }
    if !r.flags.is_empty() {
        s.push_str("<h2>Flagged epochs</h2><table><tr><th>time [s]</th><th>test</th><th>sensor blamed</th></tr>");
        for f in r.flags.iter().take(EVENTS_LISTED) {
            let _ =
                write!(s, "<tr><td>{:.3}</td><td>{}</td><td>{}</td></tr>", f.time, escape(&f.test), escape(&f.sensor));
        }
        s.push_str("</table>");
    }
    let cut = r.rejected.len().max(r.flags.len());
    if cut > EVENTS_LISTED {
        let _ = write!(s, "<p class=\"muted\">Lists cut at {EVENTS_LISTED} rows; report.json has all.</p>");
    }
}
