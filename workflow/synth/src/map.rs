//! A PNG map of a whole campaign for people to look at: buildings (light grey bounding boxes), street centre
//! lines (dark grey), pole-like objects (dots in their class colour), aerial frame footprints (blue outlines)
//! and the drive coloured by the horizontal DG error (green 0 → red 1 m). North up, square pixels.
//! [`StreamedMap`] draws the same layers piece by piece in bounded memory, for drives of any length.

mod stream;

use image::{Rgb, RgbImage};
use plumbline_geo::MapFromCamera;

pub use stream::StreamedMap;

use crate::motion::Drive;
use crate::motion::dg::DgSolution;
use crate::render::{RenderError, encode_png_rgb};
use crate::world::{PoleClass, World};

/// Horizontal DG error drawn red, metres (green at 0).
const RED_AT: f64 = 1.0;

/// PNG bytes of the map of `world`, `width_px` wide, with the drive and the ground footprints of the
/// aerial frames (`footprints`: each frame's four ground corners, easting/northing).
pub fn campaign_map_png(
    world: &World,
    drive: &Drive,
    dg: &DgSolution,
    footprints: &[[[f64; 2]; 4]],
    width_px: u32,
) -> Result<Vec<u8>, RenderError> {
    let (lo, hi) = world.bounds();
    let width = width_px.max(16);
    let scale = f64::from(width) / (hi[0] - lo[0]).max(1.0);
    let height = (((hi[1] - lo[1]) * scale).ceil() as u32).max(16);
    let to_px = |p: [f64; 2]| ((p[0] - lo[0]) * scale, (hi[1] - p[1]) * scale);
    let mut img = RgbImage::from_pixel(width, height, Rgb([255, 255, 255]));
    for b in &world.buildings {
        let c = b.shape.corners();
        let (u0, v0) = to_px([
            c.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min),
            c.iter().map(|p| p[1]).fold(f64::NEG_INFINITY, f64::max),
        ]);
        let (u1, v1) = to_px([
            c.iter().map(|p| p[0]).fold(f64::NEG_INFINITY, f64::max),
            c.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min),
        ]);
        fill(&mut img, (u0, v0), (u1, v1), Rgb([215, 215, 215]));
    }
    for s in &world.streets {
        for w in s.points.windows(2) {
            line(&mut img, to_px([w[0][0], w[0][1]]), to_px([w[1][0], w[1][1]]), Rgb([90, 90, 90]));
        }
    }
    for f in footprints {
        for k in 0..4 {
            line(&mut img, to_px(f[k]), to_px(f[(k + 1) % 4]), Rgb([60, 90, 230]));
        }
    }
    for p in &world.poles {
        let (u, v) = to_px([p.base[0], p.base[1]]);
        fill(&mut img, (u - 1.5, v - 1.5), (u + 1.5, v + 1.5), class_colour(p.class));
    }
    let mut next = 0.0;
    for ((rec, k), e) in drive.trajectory.records().iter().zip(&drive.kinematics).zip(&dg.errors) {
        if k.distance >= next {
            next = k.distance + 0.5;
            let red = (e.position.x().hypot(e.position.y()) / RED_AT).clamp(0.0, 1.0);
            let (u, v) = to_px([rec.position.x(), rec.position.y()]);
            let c = Rgb([(255.0 * red) as u8, (200.0 * (1.0 - red)) as u8, 0]);
            fill(&mut img, (u - 1.0, v - 1.0), (u + 1.0, v + 1.0), c);
        }
    }
    encode_png_rgb(&img)
}

/// The ground corners of a nadir frame of `width` × `height` pixels at ground sample distance `gsd`.
pub fn footprint(pose: &MapFromCamera, width: u32, height: u32, gsd: f64) -> [[f64; 2]; 4] {
    let (hw, hh) = (f64::from(width) * gsd / 2.0, f64::from(height) * gsd / 2.0);
    let m = pose.rotation.matrix();
    let c = pose.translation;
    // Camera x and y axes on the ground (nadir: the rotation's first two columns, horizontal parts).
    let corner = |sx: f64, sy: f64| {
        [c.x() + sx * hw * m[(0, 0)] + sy * hh * m[(0, 1)], c.y() + sx * hw * m[(1, 0)] + sy * hh * m[(1, 1)]]
    };
    [corner(-1.0, -1.0), corner(1.0, -1.0), corner(1.0, 1.0), corner(-1.0, 1.0)]
}

fn class_colour(class: PoleClass) -> Rgb<u8> {
    match class {
        PoleClass::StreetLight => Rgb([0, 140, 60]),
        PoleClass::SignPost => Rgb([120, 120, 130]),
        PoleClass::TrafficLight => Rgb([0, 0, 0]),
        PoleClass::Tree => Rgb([140, 90, 40]),
    }
}

/// Fill the pixel rectangle between two corners (any order), clipped.
fn fill(img: &mut RgbImage, a: (f64, f64), b: (f64, f64), colour: Rgb<u8>) {
    let clip = |x: f64, n: u32| x.clamp(0.0, f64::from(n)) as u32;
    let (u0, u1) = (clip(a.0.min(b.0), img.width()), clip(a.0.max(b.0), img.width()));
    let (v0, v1) = (clip(a.1.min(b.1), img.height()), clip(a.1.max(b.1), img.height()));
    for v in v0..v1.max(v0 + 1).min(img.height()) {
        for u in u0..u1.max(u0 + 1).min(img.width()) {
            img.put_pixel(u, v, colour);
        }
    }
}

/// A one-pixel line, sampled every half pixel, clipped.
fn line(img: &mut RgbImage, a: (f64, f64), b: (f64, f64), colour: Rgb<u8>) {
    let n = ((b.0 - a.0).hypot(b.1 - a.1) * 2.0).ceil().max(1.0) as usize;
    for i in 0..=n {
        let t = i as f64 / n as f64;
        let (u, v) = (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
        if u >= 0.0 && v >= 0.0 && u < f64::from(img.width()) && v < f64::from(img.height()) {
            img.put_pixel(u as u32, v as u32, colour);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use plumbline_geo::{Camera, Point3, Rotation};

    #[test]
    fn footprint_of_a_level_frame_is_its_ground_rectangle() {
        // Nadir camera: camera x = east, y = south (image down), z = down.
        let m = nalgebra::Matrix3::new(1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0);
        let pose = MapFromCamera::new(
            Rotation::<plumbline_geo::Map, Camera>::from_matrix(&m),
            Point3::new(100.0, 200.0, 900.0),
        );
        let f = footprint(&pose, 1000, 750, 0.12);
        // Top-left of the image (−x, −y) is north-west: 60 m west, 45 m north.
        assert!((f[0][0] - 40.0).abs() < 1e-9 && (f[0][1] - 245.0).abs() < 1e-9, "{f:?}");
        assert!((f[2][0] - 160.0).abs() < 1e-9 && (f[2][1] - 155.0).abs() < 1e-9, "{f:?}");
    }
}
