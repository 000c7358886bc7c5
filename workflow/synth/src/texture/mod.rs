//! The procedural ground texture: a colour at any map point for any sample footprint, at either epoch.
//!
//! Asphalt with noise and repairs, manholes, painted markings (lane lines, stop lines, zebra crossings,
//! arrows; worn or missing at the aerial epoch), kerbstones, sidewalk paving and yards between the streets.

mod filter;
mod markings;
pub mod markings_truth;
mod materials;

pub use filter::{fbm, hash, pulses, stripe, unit};
pub use markings_truth::{MarkingKind, MarkingTruth, markings_csv, road_markings};

use crate::world::polyline::{self, Station};
use crate::world::{Epoch, Street, World};
use filter::mix;

/// Linear RGB in [0, 1].
pub type Rgb = [f32; 3];

/// The ground of a world at one epoch.
#[derive(Clone, Copy, Debug)]
pub struct Texture<'w> {
    /// The world whose streets decide the layout.
    pub world: &'w World,
    /// Which epoch's paint, repairs and wear to show.
    pub epoch: Epoch,
}

/// Where a point lies relative to the street it belongs to.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Place<'w> {
    pub street: &'w Street,
    pub station: Station,
    /// Distance to the nearest junction area's edge along the street, from `from` and from `to`, metres.
    pub from_end: f64,
    pub to_end: f64,
    /// Inside a junction area.
    pub in_junction: bool,
}

impl<'w> Texture<'w> {
    /// The ground texture of `world` as it was at `epoch`.
    pub fn new(world: &'w World, epoch: Epoch) -> Self {
        Self { world, epoch }
    }

    /// Ground albedo (linear RGB) at map point (`e`, `n`), averaged over a square footprint of `footprint_m`.
    pub fn albedo(&self, e: f64, n: f64, footprint_m: f64) -> Rgb {
        let fp = footprint_m.max(1e-3);
        let seed = self.world.config.seed;
        let (x, y) = (e - self.world.config.origin_east, n - self.world.config.origin_north);
        let Some(place) = self.place([e, n]) else { return materials::yard(seed, x, y, fp) };
        let st = place.street;
        let t = place.station.t.abs();
        let cw = st.carriageway() / 2.0;
        let road_w = if place.in_junction { 1.0 } else { stripe(t, -1.0, cw, fp) };
        let kerb_w = stripe(t, cw, cw + st.kerb, fp);
        let walk_w = stripe(t, cw + st.kerb, cw + st.kerb + st.sidewalk, fp);
        let yard_w = (1.0 - road_w - kerb_w - walk_w).max(0.0);
        let mut acc = [0.0f32; 3];
        let mut add = |w: f32, c: Rgb| {
            for k in 0..3 {
                acc[k] += w * c[k];
            }
        };
        if road_w > 0.0 {
            add(road_w, self.road(&place, x, y, fp));
        }
        if kerb_w > 0.0 {
            add(kerb_w, materials::kerb(seed, place.station.s, x, y, fp));
        }
        if walk_w > 0.0 {
            let local = (place.station.s, t - cw - st.kerb);
            add(walk_w, materials::paving(seed, st.key, local, x, y, fp));
        }
        if yard_w > 0.0 {
            add(yard_w, materials::yard(seed, x, y, fp));
        }
        acc
    }

    fn road(&self, place: &Place, x: f64, y: f64, fp: f64) -> Rgb {
        let seed = self.world.config.seed;
        let base = materials::asphalt(seed, self.epoch, x, y, fp);
        let base = materials::manholes(place, base, fp);
        let (paint, strength) = markings::paint(place, self.epoch, seed, fp);
        mix(base, markings::WHITE, paint * strength)
    }

    /// The street a point belongs to: the one whose carriageway is nearest; `None` far from all streets.
    pub(crate) fn place(&self, p: [f64; 2]) -> Option<Place<'w>> {
        let w = self.world;
        let mut best: Option<(f64, &Street, Station)> = None;
        for &(sid, seg) in w.street_grid.at(p) {
            let st = &w.streets[sid as usize];
            let (station, _) = polyline::station_on_segment(&st.points, &st.cum, seg as usize, p);
            let key = station.t.abs() - st.carriageway() / 2.0;
            if best.as_ref().is_none_or(|b| key < b.0) {
                best = Some((key, st, station));
            }
        }
        let (key, street, station) = best?;
        let (j0, j1) = (&w.junctions[street.from as usize], &w.junctions[street.to as usize]);
        // The junction area is paved where it is near some carriageway (rounded corners), not over the kerbs.
        let in_junction = key < 1.0
            && w.junction_grid
                .at(p)
                .iter()
                .any(|&j| polyline::dist(w.junctions[j as usize].pos, p) < w.junctions[j as usize].radius - 1.0);
        Some(Place {
            street,
            station,
            from_end: station.s - j0.radius,
            to_end: street.length() - station.s - j1.radius,
            in_junction,
        })
    }
}
