//! Road markings in street coordinates: centre and lane lines (solid or dashed), parking edge lines,
//! stop lines, zebra crossings at junctions and turn arrows on arterials; each element worn, repainted or
//! missing by epoch.

use super::filter::{hash, pulses, sdf_cover, stripe, unit};
use super::{Place, Rgb};
use crate::world::{Epoch, StreetClass};

/// Fresh road paint.
pub const WHITE: Rgb = [0.86, 0.86, 0.83];
/// Half width of a lane line, metres.
const LINE: f64 = 0.06;
/// Where lane lines stop before a junction area: the crossing and the stop line lie in between.
const CLEAR: f64 = 5.0;

/// Paint coverage at a place and the paint's strength (wear) at the epoch.
pub fn paint(place: &Place, epoch: Epoch, seed: u64, fp: f64) -> (f32, f32) {
    let st = place.street;
    if !st.markings || place.in_junction {
        return (0.0, 0.0);
    }
    let (s, t) = (place.station.s, place.station.t);
    let near_from = place.from_end < place.to_end;
    let end = if near_from { place.from_end } else { place.to_end };
    // Element ids for wear: lines by street, crossings and stop lines by street end.
    let (cover, element) = if end < CLEAR {
        (junction_paint(place, end, near_from, fp), 2 + i64::from(near_from))
    } else {
        let arrows = if st.class == StreetClass::Arterial { arrow(place, end, near_from, fp) } else { 0.0 };
        (lines(place, s + dash_shift(seed, i64::from(st.key), epoch), t, fp).max(arrows), 1)
    };
    (cover, strength(seed, i64::from(st.key), element, epoch))
}

/// Where the dashes were repainted between the epochs (15 % of streets), the aerial image shows them at
/// another phase: a trap for matching that a lane line's direction alone cannot resolve.
fn dash_shift(seed: u64, street: i64, epoch: Epoch) -> f64 {
    let r = unit(seed ^ 54, street, 0);
    if epoch == Epoch::Aerial && r < 0.15 { 1.5 + 20.0 * f64::from(r) } else { 0.0 }
}

fn lines(place: &Place, s: f64, t: f64, fp: f64) -> f32 {
    let st = place.street;
    let lanes = f64::from(st.lanes) * st.lane_width;
    let across = |c: f64| stripe(t, c - LINE, c + LINE, fp);
    let dashed = |c: f64| across(c) * pulses(s, 9.0, 0.0, 3.0, fp);
    let centre = match st.class {
        StreetClass::Arterial => across(-0.15).max(across(0.15)),
        _ => dashed(0.0),
    };
    let mut cover = centre;
    for k in 1..st.lanes {
        let c = f64::from(k) * st.lane_width;
        cover = cover.max(dashed(c)).max(dashed(-c));
    }
    if st.parking > 0.0 {
        cover = cover.max(across(lanes)).max(across(-lanes));
    }
    cover
}

/// Zebra crossing (where the junction has one) and the stop line of the approaching lanes.
fn junction_paint(place: &Place, end: f64, near_from: bool, fp: f64) -> f32 {
    let st = place.street;
    let t = place.station.t;
    let half = st.carriageway() / 2.0;
    let j = if near_from { st.end_keys[0] } else { st.end_keys[1] };
    let zebra = !hash(0x2EB2A, i64::from(j), i64::from(st.key)).is_multiple_of(3);
    let stripes = if zebra { stripe(end, 0.3, 3.3, fp) * pulses(t + half, 1.0, 0.25, 0.5, fp) } else { 0.0 };
    // Traffic approaching this end drives on the side where t has the sign of `near_from`.
    let approach = if near_from { stripe(t, 0.0, half, fp) } else { stripe(t, -half, 0.0, fp) };
    let stop = stripe(end, 3.8, 4.3, fp) * approach;
    stripes.max(stop)
}

/// A straight-ahead arrow 8–13 m before the stop line in each approaching lane.
fn arrow(place: &Place, end: f64, near_from: bool, fp: f64) -> f32 {
    let st = place.street;
    let a = end - 8.0;
    if !(-1.0..6.0).contains(&a) {
        return 0.0;
    }
    // Lane-local across coordinate, positive away from the centre line.
    let t = if near_from { place.station.t } else { -place.station.t };
    let lane = (t / st.lane_width).floor();
    if lane < 0.0 || lane >= f64::from(st.lanes) {
        return 0.0;
    }
    let c = t - (lane + 0.5) * st.lane_width;
    // The head points toward the junction (decreasing `end`): head for a in [0, 1.5], shaft beyond.
    let shaft = stripe(a, 1.5, 5.0, fp) * stripe(c, -0.15, 0.15, fp);
    let head_sd = (0.6 * a / 1.5 - c.abs()).min(a).min(1.5 - a);
    shaft.max(sdf_cover(head_sd, fp))
}

/// Paint strength of an element: mostly fresh at the mobile epoch; a quarter worn and some missing
/// (repainted since, or removed) at the aerial epoch (paper 000 §4.2, Figure 8).
fn strength(seed: u64, street: i64, element: i64, epoch: Epoch) -> f32 {
    let r = unit(seed ^ 51, street, element);
    match epoch {
        Epoch::Mobile => {
            if r < 0.1 {
                0.5
            } else {
                1.0
            }
        }
        Epoch::Aerial => {
            let q = unit(seed ^ 52, street, element);
            if q < 0.07 {
                0.0
            } else if q < 0.32 {
                0.3 + 0.3 * unit(seed ^ 53, street, element)
            } else {
                1.0
            }
        }
    }
}
