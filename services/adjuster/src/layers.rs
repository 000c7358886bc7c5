//! The point layers of `observations.gpkg`, in the campaign CRS: tie points, pole detections and matches,
//! coordinate updates, rejected observations, flagged epochs, panoramas, and from the point clouds the
//! detected poles and the cadastre changes. Points only (what
//! `plumbline_runtime::gdal_write` writes); a feature without finite coordinates is left out.

use std::collections::{HashMap, HashSet};

use plumbline_adjustment::{ObservationRef, RejectedObservation};
use plumbline_campaign::Campaign;
use plumbline_geo::{PositionInterpolation, Trajectory};
use plumbline_runtime::gdal_write::{FieldType, FieldValue, PointFeature, PointLayer};
use serde::Serialize;

use crate::merge::{Merged, tile_name};
use crate::refs;
use crate::report::flags;
use crate::report::series::matched_position;
use crate::solve::Solved;

use FieldType::{Integer as I, Real as R, Text as T};

/// Names of the layers, in the order they are written.
pub const LAYERS: [&str; 9] = [
    "tie_points",
    "pole_detections",
    "pole_matches",
    "coordinate_updates",
    "rejected_observations",
    "flagged_epochs",
    "panoramas",
    "detected_poles",
    "cadastre_changes",
];

struct Layer(PointLayer);

impl Layer {
    fn new(name: &str, fields: &[(&str, FieldType)]) -> Self {
        let fields = fields.iter().map(|(n, t)| ((*n).to_owned(), *t)).collect();
        Self(PointLayer { name: name.to_owned(), fields, features: Vec::new() })
    }

    fn push(&mut self, at: [f64; 2], values: Vec<FieldValue>) {
        if at.iter().all(|v| v.is_finite()) {
            self.0.features.push(PointFeature { x: at[0], y: at[1], values });
        }
    }
}

fn text(s: impl Into<String>) -> FieldValue {
    FieldValue::Text(s.into())
}

fn real(v: f64) -> FieldValue {
    FieldValue::Real(v)
}

fn int(v: impl TryInto<i64>) -> FieldValue {
    FieldValue::Integer(v.try_into().unwrap_or(i64::MAX))
}

/// A unit enum's serde name (`no_candidate`, `light`, …).
fn label(v: &impl Serialize) -> String {
    match serde_json::to_value(v) {
        Ok(serde_json::Value::String(s)) => s,
        Ok(other) => other.to_string(),
        Err(_) => String::new(),
    }
}

fn dg_at(dg: &Trajectory, t: f64) -> [f64; 2] {
    dg.interpolate(t, PositionInterpolation::Linear).map_or([f64::NAN; 2], |r| [r.position.x(), r.position.y()])
}

/// All layers of `observations.gpkg` (names in [`LAYERS`]).
pub fn observation_layers(campaign: &Campaign, merged: &Merged, solved: &Solved) -> Vec<PointLayer> {
    let dg = &campaign.trajectory.trajectory;
    let rejected = &solved.adjustment.rejected;
    vec![
        tie_points(merged, solved),
        pole_detections(merged),
        pole_matches(merged),
        coordinate_updates(merged, rejected),
        rejected_observations(merged, rejected, dg),
        flagged_epochs(solved, dg),
        panoramas(campaign, merged),
        detected_poles(merged, dg, &solved.corrected),
        cadastre_changes(merged, dg, &solved.corrected),
    ]
}

/// The correction (corrected − DG, east and north) at `t`.
fn correction_at(dg: &Trajectory, corrected: &Trajectory, t: f64) -> [f64; 2] {
    let (a, b) = (dg_at(dg, t), dg_at(corrected, t));
    [b[0] - a[0], b[1] - a[1]]
}

/// The stems the point clouds showed (frames `point_clouds[i]@…`), each once, at its centre moved by the
/// trajectory's correction at its time: the pole and tree inventory of the drive, with the cadastre object
/// it matched. A cloud's stem is in the DG frame of its scan time; the correction takes it to the adjusted
/// one.
fn detected_poles(merged: &Merged, dg: &Trajectory, corrected: &Trajectory) -> PointLayer {
    let fields = [("frame", T), ("time", R), ("diameter_m", R), ("sigma_m", R), ("lowest_m", R), ("highest_m", R)];
    let more = [("lean", R), ("range_m", R), ("observed_e", R), ("observed_n", R), ("cadastre_id", T)];
    let mut layer = Layer::new(LAYERS[7], &[&fields[..], &more[..]].concat());
    for f in merged.pole_frames.iter().filter(|f| f.frame.starts_with("point_clouds[")) {
        let c = correction_at(dg, corrected, f.time);
        for (k, d) in f.detections.iter().enumerate() {
            let matched = f.matches.iter().find(|m| m.detection == k).map(|m| m.cadastre_id.clone());
            let [lowest, highest] = d.height_extent_m;
            let values = vec![text(f.frame.clone()), real(f.time), real(d.diameter_m), real(d.sigma())];
            let rest =
                [real(lowest), real(highest), real(d.lean), real(d.range_m), real(d.centre[0]), real(d.centre[1])];
            let at = [d.centre[0] + c[0], d.centre[1] + c[1]];
            layer.push(at, [values, rest.to_vec(), vec![text(matched.unwrap_or_default())]].concat());
        }
    }
    layer.0
}

/// What the point clouds say of the cadastre: stems with no cadastre object of a compatible class within the
/// matching gate in a slice whose other stems did match (so the DG error was within the gate there; in a
/// slice where nothing matched, the trajectory may be off by more than the gate), as `change` =
/// `not_in_cadastre` at the corrected position, for an agency to review. Stems left unmatched for other
/// reasons (ambiguous, a rival nearby) are not changes and are left out. And cadastre poles the clouds should
/// have shown: within `cover_m` of the scanner in a slice whose stems matched, matched by no slice of any
/// cloud, as `not_seen` at the cadastre's position (gone in reality — or hidden behind a parked car or a
/// hedge when scanned: a prompt to look, not a verdict).
fn cadastre_changes(merged: &Merged, dg: &Trajectory, corrected: &Trajectory) -> PointLayer {
    let fields = [("change", T), ("cadastre_id", T), ("class", T), ("frame", T), ("time", R), ("diameter_m", R)];
    let mut layer = Layer::new(LAYERS[8], &[&fields[..], &[("sigma_m", R), ("highest_m", R)][..]].concat());
    let clouds: Vec<_> =
        merged.pole_frames.iter().filter(|f| f.frame.starts_with("point_clouds[") && f.offset.is_some()).collect();
    for f in &clouds {
        let c = correction_at(dg, corrected, f.time);
        for u in f.unmatched.iter().filter(|u| label(&u.reason) == "no_candidate") {
            let Some(d) = f.detections.get(u.detection) else { continue };
            let at = [d.centre[0] + c[0], d.centre[1] + c[1]];
            let values = vec![text("not_in_cadastre"), text(""), text(""), text(f.frame.clone()), real(f.time)];
            let rest = [real(d.diameter_m), real(d.sigma()), real(d.height_extent_m[1])];
            layer.push(at, [values, rest.to_vec()].concat());
        }
    }
    // In the cadastre but not seen: within a slice's cover, matched by no slice of any cloud.
    let matched: HashSet<&str> = merged
        .pole_frames
        .iter()
        .filter(|f| f.frame.starts_with("point_clouds["))
        .flat_map(|f| f.matches.iter().map(|m| m.cadastre_id.as_str()))
        .collect();
    let mut listed: HashSet<&str> = HashSet::new();
    for f in &clouds {
        for u in f.unseen.iter().filter(|u| !matched.contains(u.cadastre_id.as_str())) {
            if listed.insert(u.cadastre_id.as_str()) {
                let values = vec![text("not_seen"), text(u.cadastre_id.clone()), text(label(&u.class))];
                let rest = [text(f.frame.clone()), real(f.time), real(f64::NAN), real(f64::NAN), real(f64::NAN)];
                layer.push(u.position, [values, rest.to_vec()].concat());
            }
        }
    }
    layer.0
}

/// Tie points at their aerial coordinates (or the adjusted ones when they have none).
fn tie_points(merged: &Merged, solved: &Solved) -> PointLayer {
    let fields = [("id", T), ("rays", I), ("source", T), ("height", R), ("sigma_e", R), ("sigma_n", R)];
    let more = [("sigma_h", R), ("adjusted_e", R), ("adjusted_n", R), ("adjusted_h", R), ("rejected", I)];
    let mut layer = Layer::new(LAYERS[0], &[&fields[..], &more[..]].concat());
    let adjusted: HashMap<&str, [f64; 3]> =
        solved.adjustment.points.iter().map(|p| (p.id.0.as_str(), p.position)).collect();
    let rejected: HashSet<usize> =
        solved.adjustment.rejected.iter().map(|r| refs::owner(&r.item)).filter(|o| o.0 == "tie").map(|o| o.1).collect();
    for (i, tie) in merged.observations.ties.iter().enumerate() {
        let adj = adjusted.get(tie.id.0.as_str()).copied();
        let (at, source, sigma) = match (tie.aerial, adj) {
            (Some(a), _) => (a.position, "aerial", std::array::from_fn(|k| a.covariance[k][k].sqrt())),
            (None, Some(p)) => (p, "adjusted", [f64::NAN; 3]),
            (None, None) => continue,
        };
        let adj = adj.unwrap_or([f64::NAN; 3]);
        let values = vec![text(tie.id.0.clone()), int(tie.rays.len()), text(source), real(at[2]), real(sigma[0])];
        let rest = [real(sigma[1]), real(sigma[2]), real(adj[0]), real(adj[1]), real(adj[2])];
        layer.push([at[0], at[1]], [values, rest.to_vec(), vec![int(rejected.contains(&i) as u8)]].concat());
    }
    layer.0
}

/// Every pole detection at its DG-observed centre, with the cadastre pole it matched or why not.
fn pole_detections(merged: &Merged) -> PointLayer {
    let fields = [("frame", T), ("time", R), ("detection", I), ("diameter_m", R), ("sigma_m", R), ("range_m", R)];
    let more = [("reliable", I), ("cadastre_id", T), ("unmatched", T)];
    let mut layer = Layer::new(LAYERS[1], &[&fields[..], &more[..]].concat());
    for f in &merged.pole_frames {
        for (k, d) in f.detections.iter().enumerate() {
            let matched = f.matches.iter().find(|m| m.detection == k).map(|m| m.cadastre_id.clone());
            let unmatched = f.unmatched.iter().find(|u| u.detection == k).map(|u| label(&u.reason));
            let values = vec![text(f.frame.clone()), real(f.time), int(k), real(d.diameter_m), real(d.sigma())];
            let rest = [real(d.range_m), int(d.reliable as u8), text(matched.unwrap_or_default())];
            layer.push(d.centre, [values, rest.to_vec(), vec![text(unmatched.unwrap_or_default())]].concat());
        }
    }
    layer.0
}

/// Every match at the matched cadastre position, with the DG-observed centre beside it.
fn pole_matches(merged: &Merged) -> PointLayer {
    let fields = [("cadastre_id", T), ("class", T), ("frame", T), ("time", R), ("observed_e", R), ("observed_n", R)];
    let more = [("residual_e", R), ("residual_n", R), ("no_update", T)];
    let mut layer = Layer::new(LAYERS[2], &[&fields[..], &more[..]].concat());
    for f in &merged.pole_frames {
        for m in &f.matches {
            let (Some(at), Some(d)) = (matched_position(f, m.detection, m.residual), f.detections.get(m.detection))
            else {
                continue;
            };
            let values = vec![text(m.cadastre_id.clone()), text(label(&m.class)), text(f.frame.clone()), real(f.time)];
            let rest = [real(d.centre[0]), real(d.centre[1]), real(m.residual[0]), real(m.residual[1])];
            let why = text(m.no_update.as_ref().map(label).unwrap_or_default());
            layer.push(at, [values, rest.to_vec(), vec![why]].concat());
        }
    }
    layer.0
}

/// The pole coordinate updates the adjustment got, at the cadastre position.
fn coordinate_updates(merged: &Merged, rejected: &[RejectedObservation]) -> PointLayer {
    let fields = [("cadastre_id", T), ("time", R), ("observed_e", R), ("observed_n", R), ("d_e", R), ("d_n", R)];
    let more = [("sigma", R), ("rejected", I), ("w_test", R)];
    let mut layer = Layer::new(LAYERS[3], &[&fields[..], &more[..]].concat());
    let w: HashMap<usize, f64> = rejected
        .iter()
        .filter_map(|r| match r.item {
            ObservationRef::Pole { index, .. } => Some((index, r.w)),
            _ => None,
        })
        .collect();
    for (i, p) in merged.observations.poles.iter().enumerate() {
        let [de, dn] = p.difference();
        let values = vec![text(p.cadastre_id.clone()), real(p.time), real(p.observed[0]), real(p.observed[1])];
        let rest = [real(de), real(dn), real(p.sigma()), int(w.contains_key(&i) as u8)];
        layer.push(p.cadastre, [values, rest.to_vec(), vec![real(w.get(&i).copied().unwrap_or(f64::NAN))]].concat());
    }
    layer.0
}

/// Observations rejected by data snooping, where they lie (else the DG position at their epoch).
fn rejected_observations(merged: &Merged, rejected: &[RejectedObservation], dg: &Trajectory) -> PointLayer {
    let fields = [("kind", T), ("id", T), ("time", R), ("w_test", R), ("round", I)];
    let mut layer = Layer::new(LAYERS[4], &fields);
    let set = &merged.observations;
    for r in rejected {
        let time = refs::time(set, &r.item).unwrap_or(f64::NAN);
        let at = refs::place(set, &r.item).unwrap_or_else(|| dg_at(dg, time));
        layer.push(at, vec![text(refs::kind(&r.item)), text(refs::id(&r.item)), real(time), real(r.w), int(r.round)]);
    }
    layer.0
}

/// Flagged epochs at the DG position.
fn flagged_epochs(solved: &Solved, dg: &Trajectory) -> PointLayer {
    let mut layer = Layer::new(LAYERS[5], &[("time", R), ("test", T), ("sensor", T)]);
    for f in flags(solved) {
        layer.push(dg_at(dg, f.time), vec![real(f.time), text(f.test), text(f.sensor)]);
    }
    layer.0
}

/// Every planned panorama at its DG position: matched, discarded (with the reason) or not registered.
fn panoramas(campaign: &Campaign, merged: &Merged) -> PointLayer {
    let fields = [("image_id", T), ("time", R), ("tile", T), ("state", T), ("reason", T), ("detail", T)];
    let mut layer = Layer::new(LAYERS[6], &fields);
    let outcomes: HashMap<&str, &crate::merge::ImageOutcome> =
        merged.images.iter().map(|i| (i.image.as_str(), i)).collect();
    for p in &campaign.plan.panoramas {
        let (tile, state, reason, detail) = match outcomes.get(p.image_id.as_str()) {
            Some(o) => match &o.discarded {
                None => (tile_name(&o.tile), "matched", String::new(), String::new()),
                Some((key, detail)) => (tile_name(&o.tile), "discarded", key.clone(), detail.clone()),
            },
            None => {
                let tile = campaign.plan.tiles.tile_of(p.id).map(tile_name).unwrap_or_default();
                (tile, "not_registered", String::new(), String::new())
            }
        };
        let values = vec![text(p.image_id.clone()), real(p.time), text(tile), text(state), text(reason), text(detail)];
        layer.push([p.east, p.north], values);
    }
    layer.0
}
