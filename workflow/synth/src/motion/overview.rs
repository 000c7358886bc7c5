//! A PNG overview map of a drive for people to look at: the true track coloured by the horizontal DG error,
//! standstills as black squares.
//!
//! North up, square pixels, a 5 % margin. Colour ramp of the horizontal error: green at 0, yellow at
//! 0.25 m, red from 1 m. The track is drawn every 0.5 m of driving as 3 × 3 pixel dots.

use image::{Rgb, RgbImage};

use super::Drive;
use super::dg::DgSolution;
use crate::render::{RenderError, encode_png_rgb};

/// Error at which the ramp turns yellow, m.
const YELLOW_AT: f64 = 0.25;
/// Error from which the ramp is red, m.
const RED_AT: f64 = 1.0;

/// PNG bytes of the overview, `width_px` wide (height from the drive's extent, at most `width_px`).
pub fn overview_png(drive: &Drive, dg: &DgSolution, width_px: u32) -> Result<Vec<u8>, RenderError> {
    let r = drive.trajectory.records();
    let (mut lo, mut hi) = ((f64::INFINITY, f64::INFINITY), (f64::NEG_INFINITY, f64::NEG_INFINITY));
    for p in r.iter().map(|x| x.position) {
        lo = (lo.0.min(p.x()), lo.1.min(p.y()));
        hi = (hi.0.max(p.x()), hi.1.max(p.y()));
    }
    let extent = (hi.0 - lo.0).max(hi.1 - lo.1).max(1.0) * 1.1;
    let width = width_px.max(16);
    let scale = f64::from(width) / extent;
    let height = (((hi.1 - lo.1) * 1.1 * scale).ceil() as u32).clamp(16, width);
    let origin = ((lo.0 + hi.0) / 2.0, (lo.1 + hi.1) / 2.0);
    let to_px = |e: f64, n: f64| {
        let u = f64::from(width) / 2.0 + (e - origin.0) * scale;
        let v = f64::from(height) / 2.0 - (n - origin.1) * scale;
        (u.floor() as i64, v.floor() as i64)
    };
    let mut img = RgbImage::from_pixel(width, height, Rgb([255, 255, 255]));
    let mut next = 0.0;
    for ((rec, k), e) in r.iter().zip(&drive.kinematics).zip(&dg.errors) {
        if k.distance < next {
            continue;
        }
        next = k.distance + 0.5;
        let (u, v) = to_px(rec.position.x(), rec.position.y());
        dot(&mut img, u, v, 1, ramp(e.position.x().hypot(e.position.y())));
    }
    for stop in &drive.stops {
        let i = drive.kinematics.partition_point(|k| k.distance < stop.s).min(r.len() - 1);
        let (u, v) = to_px(r[i].position.x(), r[i].position.y());
        dot(&mut img, u, v, 3, Rgb([0, 0, 0]));
    }
    encode_png_rgb(&img)
}

/// Green → yellow → red with the horizontal error.
fn ramp(error: f64) -> Rgb<u8> {
    let channel = |x: f64| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
    if error <= YELLOW_AT {
        Rgb([channel(error / YELLOW_AT), 200, 0])
    } else {
        Rgb([255, channel(200.0 / 255.0 * (1.0 - (error - YELLOW_AT) / (RED_AT - YELLOW_AT))), 0])
    }
}

/// A filled square of half-size `r` pixels.
fn dot(img: &mut RgbImage, u: i64, v: i64, r: i64, colour: Rgb<u8>) {
    for y in v - r..=v + r {
        for x in u - r..=u + r {
            if let (Ok(x), Ok(y)) = (u32::try_from(x), u32::try_from(y))
                && x < img.width()
                && y < img.height()
            {
                img.put_pixel(x, y, colour);
            }
        }
    }
}
