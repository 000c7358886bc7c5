//! Road markings in street coordinates: centre and lane lines (solid or dashed), parking edge lines,
//! stop lines, zebra crossings at junctions and turn arrows on arterials; each element worn, repainted or
//! missing by epoch.

use super::Rgb;
use super::filter::{hash, pulses, sdf_cover, stripe, unit};
use crate::world::{Epoch, Place, Street, StreetClass};

/// Fresh road paint.
pub const WHITE: Rgb = [0.86, 0.86, 0.83];

// The geometry below is shared with the true marking polylines ([`super::markings_truth`]), so the two
// cannot drift apart. `end` is the distance along the street from the nearest junction area's edge.
/// Half width of a lane line, metres.
pub(crate) const LINE: f64 = 0.06;
/// Where lane lines stop before a junction area: the crossing and the stop line lie in between.
pub(crate) const CLEAR: f64 = 5.0;
/// Dashed lines: a dash of `DASH_LEN` at stations [k·`DASH_PERIOD`, k·`DASH_PERIOD` + `DASH_LEN`], metres.
pub(crate) const DASH_PERIOD: f64 = 9.0;
/// Length of a dash, metres.
pub(crate) const DASH_LEN: f64 = 3.0;
/// Offset of each of an arterial's two solid centre lines, metres.
pub(crate) const ARTERIAL_CENTRE: f64 = 0.15;
/// Zebra stripes lie at `end` within this range, metres.
pub(crate) const ZEBRA_END: (f64, f64) = (0.3, 3.3);
/// Zebra stripes across the carriageway: [k·period + start, k·period + start + len] from its right edge
/// (t = −half carriageway), metres.
pub(crate) const ZEBRA_PERIOD: f64 = 1.0;
/// Start of the first zebra stripe from the carriageway's right edge, metres.
pub(crate) const ZEBRA_START: f64 = 0.25;
/// Width of a zebra stripe, metres.
pub(crate) const ZEBRA_LEN: f64 = 0.5;
/// The stop line lies at `end` within this range, on the approaching half of the carriageway, metres.
pub(crate) const STOP_END: (f64, f64) = (3.8, 4.3);
/// An arrow's tip lies at this `end`; arrow-local a = end − `ARROW_TIP`, metres.
pub(crate) const ARROW_TIP: f64 = 8.0;
/// The arrow head spans a in [0, `ARROW_HEAD`], the shaft a in [`ARROW_HEAD`, `ARROW_TAIL`], metres.
pub(crate) const ARROW_HEAD: f64 = 1.5;
/// Where the shaft ends (its tail), arrow-local, metres.
pub(crate) const ARROW_TAIL: f64 = 5.0;
/// Half width of the shaft, metres.
pub(crate) const ARROW_SHAFT: f64 = 0.15;
/// Half width of the head at its base, metres.
pub(crate) const ARROW_HEAD_HALF: f64 = 0.6;

/// The longitudinal lines of a street, each as (offset t, dashed): the centre line(s), lane lines and parking
/// edge lines. Painted where `end` ≥ [`CLEAR`].
pub(crate) fn each_line(st: &Street, mut f: impl FnMut(f64, bool)) {
    match st.class {
        StreetClass::Arterial => {
            f(-ARTERIAL_CENTRE, false);
            f(ARTERIAL_CENTRE, false);
        }
        _ => f(0.0, true),
    }
    for k in 1..st.lanes {
        let c = f64::from(k) * st.lane_width;
        f(c, true);
        f(-c, true);
    }
    if st.parking > 0.0 {
        let lanes = f64::from(st.lanes) * st.lane_width;
        f(lanes, false);
        f(-lanes, false);
    }
}

/// Whether the street's end at its `from` (`near_from`) or `to` junction has a zebra crossing.
pub(crate) fn has_zebra(st: &Street, near_from: bool) -> bool {
    let j = if near_from { st.end_keys[0] } else { st.end_keys[1] };
    !hash(0x2EB2A, i64::from(j), i64::from(st.key)).is_multiple_of(3)
}

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
        (lines(s + dash_shift(seed, i64::from(st.key), epoch), t, st, fp).max(arrows), 1)
    };
    (cover, strength(seed, i64::from(st.key), element, epoch))
}

/// Where the dashes were repainted between the epochs (15 % of streets), the aerial image shows them at
/// another phase: a trap for matching that a lane line's direction alone cannot resolve.
fn dash_shift(seed: u64, street: i64, epoch: Epoch) -> f64 {
    let r = unit(seed ^ 54, street, 0);
    if epoch == Epoch::Aerial && r < 0.15 { 1.5 + 20.0 * f64::from(r) } else { 0.0 }
}

fn lines(s: f64, t: f64, st: &Street, fp: f64) -> f32 {
    let mut cover = 0.0f32;
    each_line(st, |c, dashed| {
        let across = stripe(t, c - LINE, c + LINE, fp);
        let along = if dashed { pulses(s, DASH_PERIOD, 0.0, DASH_LEN, fp) } else { 1.0 };
        cover = cover.max(across * along);
    });
    cover
}

/// Zebra crossing (where the junction has one) and the stop line of the approaching lanes.
fn junction_paint(place: &Place, end: f64, near_from: bool, fp: f64) -> f32 {
    let st = place.street;
    let t = place.station.t;
    let half = st.carriageway() / 2.0;
    let stripes = if has_zebra(st, near_from) {
        let (a, b) = ZEBRA_END;
        stripe(end, a, b, fp) * pulses(t + half, ZEBRA_PERIOD, ZEBRA_START, ZEBRA_LEN, fp)
    } else {
        0.0
    };
    // Traffic approaching this end drives on the side where t has the sign of `near_from`.
    let approach = if near_from { stripe(t, 0.0, half, fp) } else { stripe(t, -half, 0.0, fp) };
    let stop = stripe(end, STOP_END.0, STOP_END.1, fp) * approach;
    stripes.max(stop)
}

/// A straight-ahead arrow 8–13 m before the stop line in each approaching lane.
fn arrow(place: &Place, end: f64, near_from: bool, fp: f64) -> f32 {
    let st = place.street;
    let a = end - ARROW_TIP;
    if !(-1.0..ARROW_TAIL + 1.0).contains(&a) {
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
    let shaft = stripe(a, ARROW_HEAD, ARROW_TAIL, fp) * stripe(c, -ARROW_SHAFT, ARROW_SHAFT, fp);
    let head_sd = (ARROW_HEAD_HALF * a / ARROW_HEAD - c.abs()).min(a).min(ARROW_HEAD - a);
    shaft.max(sdf_cover(head_sd, fp))
}

/// Paint strength of an element: mostly fresh at the mobile epoch; a quarter worn and some missing
/// (repainted since, or removed) at the aerial epoch (Jende et al. 2017 §4.2, Figure 8).
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
