//! The procedural ground texture: a colour at any map point for any sample footprint, at either epoch.
//!
//! Asphalt with noise and repairs, manholes, painted markings (lane lines, stop lines, zebra crossings,
//! arrows; worn or missing at the aerial epoch), kerbstones, sidewalk paving and yards between the streets.

mod filter;
mod markings;
pub mod markings_truth;
mod materials;

pub use filter::{fbm, hash, pulses, stripe, unit};
pub use markings_truth::{MarkingKind, MarkingTruth, markings_csv, road_markings, road_markings_where};

use crate::world::{Epoch, Place, World};
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
        let Some(place) = self.world.place([e, n]) else { return materials::yard(seed, x, y, fp) };
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
}
