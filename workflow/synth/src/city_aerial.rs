//! The aerial products of the unbounded city (`--preset city`), made piece by piece as the drive goes on: a block
//! of nadir frames on one endless set of east–west strips anchored at the city's origin (the camera, GSD, 60 % /
//! 30 % overlaps, strip directions and AT errors of [`crate::render::plan_block`]), orthophoto and terrain tiles
//! on a square lattice, and the city window holding everything a set of frames and tiles sees: its ground, plus
//! the longest shadow a building can cast into it under the aerial sun.
//!
//! Frames and tiles are named by their lattice indices, so pieces made for different legs never collide, and
//! each is a pure function of (seed, indices): the AT error and the noise of a frame do not depend on which leg
//! made it first.

use std::collections::BTreeSet;

use plumbline_geo::MapFromCamera;
use plumbline_geo::Point3;
use plumbline_geo::camera::Pinhole;

use crate::aerial::Frame;
use crate::ortho::OrthoGrid;
use crate::render::{AtErrors, BlockSpec, Illumination, perturb_pose, strip_rotation};
use crate::world::WorldConfig;
use crate::world::city::{City, CityWindow};
use crate::world::polyline::P2;

/// Tallest building of the world (`world/placement.rs`: arterial buildings 18–40 m), metres.
const TALLEST_M: f64 = 40.0;
/// Beyond the longest shadow: the relief displacement of a 40 m roof at a frame's edge (≈ 2 m at 12 cm GSD)
/// and the crowns of trees standing outside, metres.
const EXTRA_SEEN_M: f64 = 8.0;

/// How far outside a piece of ground objects change what an aerial image of it shows: the longest cast
/// shadow under the aerial sun (40 m at 35° elevation: 57 m) plus 8 m for relief displacement and crowns, metres.
pub fn seen_margin() -> f64 {
    // Shadow length of a height h under a sun at elevation e: h / tan e.
    TALLEST_M / Illumination::aerial().sun_elevation.tan() + EXTRA_SEEN_M
}

/// A frame of the endless block: strip (northward from the origin) and step along it (eastward).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct FrameKey {
    /// Strip number; odd strips are flown westward.
    pub strip: i32,
    /// Exposure number along the strip (eastward).
    pub step: i32,
}

impl FrameKey {
    /// The image id (also the file stem), unique over the whole city.
    pub fn id(self) -> String {
        format!("aerial_s{}_k{}", self.strip, self.step)
    }
}

/// The block over the unbounded city: where every frame is and how it was flown.
#[derive(Clone, Debug)]
pub struct CityBlock {
    cam: Pinhole,
    origin: P2,
    height: f64,
    /// Ground size of a frame along and across the strip, metres.
    size: [f64; 2],
    /// Air base and strip spacing, metres.
    base: f64,
    spacing: f64,
}

impl CityBlock {
    /// The block flown with `cam` and `spec` over the city of `config` (strips anchored at its origin).
    pub fn new(config: &WorldConfig, cam: Pinhole, spec: &BlockSpec) -> Self {
        // The geometry of `plan_block`: flying height above ground = GSD · focal length in pixels (Jende et al. 2017
        // §3.2: 12 cm aerial GSD), air base and strip spacing from the 60 % / 30 % overlaps.
        let height = config.ground_height + spec.gsd * cam.fx;
        let size = [f64::from(cam.width) * spec.gsd, f64::from(cam.height) * spec.gsd];
        let base = (1.0 - spec.forward_overlap).max(0.05) * size[0];
        let spacing = (1.0 - spec.side_overlap).max(0.05) * size[1];
        Self { cam, origin: [config.origin_east, config.origin_north], height, size, base, spacing }
    }

    /// The camera.
    pub fn camera(&self) -> &Pinhole {
        &self.cam
    }

    /// Ground point under the projection centre of a frame, easting/northing.
    pub fn centre(&self, key: FrameKey) -> P2 {
        [self.origin[0] + f64::from(key.step) * self.base, self.origin[1] + f64::from(key.strip) * self.spacing]
    }

    /// The frame's nominal ground footprint (nadir, flat ground): smallest and largest corner.
    pub fn footprint(&self, key: FrameKey) -> (P2, P2) {
        let c = self.centre(key);
        let (hx, hy) = (self.size[0] / 2.0, self.size[1] / 2.0);
        ([c[0] - hx, c[1] - hy], [c[0] + hx, c[1] + hy])
    }

    /// Every frame whose footprint comes within `reach` metres (in easting and in northing) of one of `points`:
    /// all frames that see any ground within `reach` of them.
    pub fn frames_near(&self, points: &[P2], reach: f64) -> BTreeSet<FrameKey> {
        let mut out = BTreeSet::new();
        for p in points {
            let steps = index_range(p[0] - self.origin[0], self.size[0] / 2.0 + reach, self.base);
            let strips = index_range(p[1] - self.origin[1], self.size[1] / 2.0 + reach, self.spacing);
            for strip in strips.clone() {
                out.extend(steps.clone().map(|step| FrameKey { strip, step }));
            }
        }
        out
    }

    /// The true orientation of a frame.
    pub fn pose(&self, key: FrameKey) -> MapFromCamera {
        let [e, n] = self.centre(key);
        MapFromCamera::new(strip_rotation(key.strip.rem_euclid(2) == 1), Point3::new(e, n, self.height))
    }

    /// The frame with its true and AT-reported orientation (errors drawn from the frame's own seed).
    pub fn frame(&self, key: FrameKey, errors: &AtErrors, seed: u64) -> Frame {
        let truth = self.pose(key);
        let reported = perturb_pose(&truth, errors, key_seed(seed, key.strip, key.step, 0xAE71));
        Frame { id: key.id(), truth, reported }
    }
}

/// The integers k with |k · step − x| ≤ half.
fn index_range(x: f64, half: f64, step: f64) -> std::ops::RangeInclusive<i32> {
    ((x - half) / step).ceil() as i32..=((x + half) / step).floor() as i32
}

/// A seed for one lattice cell and purpose (splitmix64 of the mixed inputs).
pub fn key_seed(seed: u64, a: i32, b: i32, purpose: u64) -> u64 {
    let mut x = seed
        ^ (i64::from(a) as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (i64::from(b) as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
        ^ purpose.wrapping_mul(0x1656_67B1_9E37_79F9);
    for _ in 0..2 {
        x ^= x >> 31;
        x = x.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        x ^= x >> 29;
    }
    x
}

/// A tile of the orthophoto / terrain lattice: column (eastward) and row (northward) from the origin.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct TileKey {
    /// Column, eastward.
    pub col: i32,
    /// Row, northward.
    pub row: i32,
}

/// Square tiles of `size` metres with the lattice's south-west corner of tile (0, 0) at `origin`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TileLattice {
    /// South-west corner of tile (0, 0), easting/northing.
    pub origin: P2,
    /// Side of a tile, metres.
    pub size: f64,
}

impl TileLattice {
    /// The tile's ground box: smallest and largest corner.
    pub fn bounds(&self, key: TileKey) -> (P2, P2) {
        let lo = [self.origin[0] + f64::from(key.col) * self.size, self.origin[1] + f64::from(key.row) * self.size];
        (lo, [lo[0] + self.size, lo[1] + self.size])
    }

    /// Every tile within `reach` metres (in easting and in northing) of one of `points`.
    pub fn tiles_near(&self, points: &[P2], reach: f64) -> BTreeSet<TileKey> {
        let mut out = BTreeSet::new();
        for p in points {
            let cell = |x: f64| ((x - reach) / self.size).floor() as i32..=((x + reach) / self.size).floor() as i32;
            for row in cell(p[1] - self.origin[1]) {
                out.extend(cell(p[0] - self.origin[0]).map(|col| TileKey { col, row }));
            }
        }
        out
    }

    /// The pixel grid of a tile with `pixels` × `pixels` pixels.
    pub fn grid(&self, key: TileKey, pixels: u32) -> OrthoGrid {
        let (lo, hi) = self.bounds(key);
        OrthoGrid { west: lo[0], north: hi[1], gsd: self.size / f64::from(pixels), width: pixels, height: pixels }
    }
}

/// Points along the polyline through `points`, one every `step` metres of its length (and its ends): thins a
/// 200 Hz trajectory, fills in between sparse waypoints.
pub fn track_points(points: impl IntoIterator<Item = P2>, step: f64) -> Vec<P2> {
    let mut out: Vec<P2> = Vec::new();
    let (mut prev, mut since): (Option<P2>, f64) = (None, 0.0);
    for p in points {
        let Some(q) = prev else {
            out.push(p);
            prev = Some(p);
            continue;
        };
        let d = (p[0] - q[0]).hypot(p[1] - q[1]);
        // Points at `step` intervals of the length since the last one emitted.
        let mut at = step - since;
        while at <= d {
            let t = at / d;
            out.push([q[0] + t * (p[0] - q[0]), q[1] + t * (p[1] - q[1])]);
            at += step;
        }
        since = (since + d) % step;
        prev = Some(p);
    }
    if let (Some(p), Some(last)) = (prev, out.last())
        && *last != p
    {
        out.push(p);
    }
    out
}

/// The city window holding everything that shows in images of the ground `boxes` (each widened by
/// [`seen_margin`]); `None` for no box.
pub fn window_seeing(city: &City, boxes: impl IntoIterator<Item = (P2, P2)>) -> Option<CityWindow> {
    let margin = seen_margin();
    let (lo, hi) = boxes.into_iter().fold(None, |acc: Option<(P2, P2)>, (lo, hi)| {
        Some(match acc {
            None => (lo, hi),
            Some((a, b)) => ([a[0].min(lo[0]), a[1].min(lo[1])], [b[0].max(hi[0]), b[1].max(hi[1])]),
        })
    })?;
    Some(city.window_box([lo[0] - margin, lo[1] - margin], [hi[0] + margin, hi[1] + margin]))
}
