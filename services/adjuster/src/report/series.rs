//! The report's series and map: the correction along track, the cross-track difference to the reference
//! before and after, and the map of the track coloured by correction with panoramas and poles.

use std::collections::BTreeMap;

use plumbline_campaign::plan::PlannedImage;
use plumbline_geo::metrics::Comparison;
use plumbline_geo::{PositionInterpolation, Trajectory};
use plumbline_poles::FrameReportV1;
use plumbline_report::decimate::{keep_extremes, pick};
use plumbline_report::{CorrectionSeries, CrossTrackSeries, MapData, MapMark, MarkState, TrackPoint};

use crate::merge::Merged;

/// Points kept of a plotted series (each bucket keeps its extremes, so spikes survive).
pub const SERIES_POINTS: usize = 2000;

/// The correction (corrected − DG) per record, east/north/up, and the posterior horizontal σ (the DG σ
/// where the adjustment gave none, 0 where neither has one: the report holds finite numbers only).
pub fn corrections(dg: &Trajectory, corrected: &Trajectory) -> CorrectionSeries {
    let mut s = CorrectionSeries::default();
    for (a, b) in dg.records().iter().zip(corrected.records()) {
        let d = b.position - a.position;
        s.time.push(b.time);
        s.east.push(d.x());
        s.north.push(d.y());
        s.up.push(d.z());
        let std = b.std.or(a.std).map_or(0.0, |p| p.east.hypot(p.north));
        s.sigma_horizontal.push(std);
    }
    s
}

/// The correction series thinned for plotting.
pub fn decimated(s: &CorrectionSeries) -> CorrectionSeries {
    let keep = keep_extremes(&[&s.east, &s.north, &s.up], SERIES_POINTS);
    CorrectionSeries {
        time: pick(&s.time, &keep),
        east: pick(&s.east, &keep),
        north: pick(&s.north, &keep),
        up: pick(&s.up, &keep),
        sigma_horizontal: pick(&s.sigma_horizontal, &keep),
    }
}

/// Cross-track differences before and after, at the epochs both comparisons share, thinned.
pub fn cross_track(before: &Comparison, after: &Comparison) -> CrossTrackSeries {
    let after_at: BTreeMap<u64, f64> =
        after.differences.time.iter().zip(&after.differences.cross).map(|(t, c)| (t.to_bits(), *c)).collect();
    let mut s = CrossTrackSeries::default();
    for (t, c) in before.differences.time.iter().zip(&before.differences.cross) {
        if let Some(a) = after_at.get(&t.to_bits()) {
            s.time.push(*t);
            s.before.push(*c);
            s.after.push(*a);
        }
    }
    let keep = keep_extremes(&[&s.before, &s.after], SERIES_POINTS);
    CrossTrackSeries { time: pick(&s.time, &keep), before: pick(&s.before, &keep), after: pick(&s.after, &keep) }
}

/// The map: the corrected track (thinned, coloured by the horizontal correction), the panoramas on it
/// (used = matched to the aerial block; unused = discarded; skipped = planned but never
/// registered, when the campaign registers at all), and the cadastre poles the frames matched or saw.
pub fn map(
    corrections: &CorrectionSeries,
    corrected: &Trajectory,
    panoramas: &[PlannedImage],
    merged: &Merged,
) -> MapData {
    let horizontal: Vec<f64> = corrections.east.iter().zip(&corrections.north).map(|(e, n)| e.hypot(*n)).collect();
    let keep = keep_extremes(&[&horizontal], SERIES_POINTS);
    let records = corrected.records();
    let track = keep
        .iter()
        .filter_map(|&i| Some((records.get(i)?, horizontal.get(i)?)))
        .map(|(r, c)| TrackPoint { e: r.position.x(), n: r.position.y(), correction: *c })
        .collect();
    MapData { track, images: images(panoramas, corrected, merged), poles: poles(merged), lines: Vec::new() }
}

/// The panoramas at their corrected positions (the DG one where the corrected trajectory does not reach).
fn images(panoramas: &[PlannedImage], corrected: &Trajectory, merged: &Merged) -> Vec<MapMark> {
    let outcome: BTreeMap<&str, bool> = merged.images.iter().map(|i| (i.image.as_str(), i.matched())).collect();
    let registering = !merged.images.is_empty();
    panoramas
        .iter()
        .filter_map(|p| {
            let state = match outcome.get(p.image_id.as_str()) {
                Some(true) => MarkState::Used,
                Some(false) => MarkState::Unused,
                None if registering => MarkState::Skipped,
                None => return None,
            };
            let (e, n) = corrected
                .interpolate(p.time, PositionInterpolation::Linear)
                .map_or((p.east, p.north), |r| (r.position.x(), r.position.y()));
            Some(MapMark { id: p.image_id.clone(), e, n, state })
        })
        .collect()
}

/// The cadastre position of a match: detection centre + the frame's offset + the residual.
pub fn matched_position(frame: &FrameReportV1, detection: usize, residual: [f64; 2]) -> Option<[f64; 2]> {
    let centre = frame.detections.get(detection)?.centre;
    let offset = frame.offset.unwrap_or([0.0, 0.0]);
    Some([centre[0] + offset[0] + residual[0], centre[1] + offset[1] + residual[1]])
}

/// Cadastre poles: used when an update came from them, unused when matched without one or seen in view only.
fn poles(merged: &Merged) -> Vec<MapMark> {
    let mut marks: BTreeMap<String, MapMark> = BTreeMap::new();
    let mut put = |id: &str, at: [f64; 2], state: MarkState| {
        let mark = marks.entry(id.to_owned()).or_insert(MapMark { id: id.to_owned(), e: at[0], n: at[1], state });
        if state == MarkState::Used {
            mark.state = MarkState::Used;
        }
    };
    for p in &merged.observations.poles {
        put(&p.cadastre_id, p.cadastre, MarkState::Used);
    }
    for f in &merged.pole_frames {
        for m in &f.matches {
            if let Some(at) = matched_position(f, m.detection, m.residual) {
                put(&m.cadastre_id, at, if m.no_update.is_none() { MarkState::Used } else { MarkState::Unused });
            }
        }
        for u in &f.unseen {
            put(&u.cadastre_id, u.position, MarkState::Unused);
        }
    }
    marks.into_values().collect()
}
