//! A true orthophoto of the world: every pixel looks straight down (orthographic projection) at the
//! first surface below, with the scene's illumination. What a true-ortho production from the aerial block
//! would deliver, without its resampling errors.

use image::RgbImage;
use nalgebra::Vector3;
use rayon::prelude::*;

use crate::render::Scene;
use crate::world::World;

/// Height above the ground the vertical rays start from, metres (above every building).
const START_ABOVE_GROUND_M: f64 = 500.0;

/// The grid of an orthophoto: top-left corner of the top-left pixel, pixel size, size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrthoGrid {
    /// Easting of the left edge, metres.
    pub west: f64,
    /// Northing of the top edge, metres.
    pub north: f64,
    /// Pixel size (ground sample distance), metres.
    pub gsd: f64,
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
}

impl OrthoGrid {
    /// The grid covering the world's bounds at `gsd`.
    pub fn covering(scene: &Scene, gsd: f64) -> Self {
        let (lo, hi) = scene.world.bounds();
        let width = ((hi[0] - lo[0]) / gsd).ceil().max(1.0) as u32;
        let height = ((hi[1] - lo[1]) / gsd).ceil().max(1.0) as u32;
        Self { west: lo[0], north: hi[1], gsd, width, height }
    }

    /// Map easting/northing of a pixel centre (column, row).
    pub fn centre(&self, col: u32, row: u32) -> [f64; 2] {
        [self.west + (f64::from(col) + 0.5) * self.gsd, self.north - (f64::from(row) + 0.5) * self.gsd]
    }

    /// GDAL geotransform of the grid.
    pub fn geotransform(&self) -> [f64; 6] {
        [self.west, self.gsd, 0.0, self.north, 0.0, -self.gsd]
    }
}

/// Render the orthophoto of `grid` (rows in parallel; each pixel a pure function of its centre).
pub fn render_orthophoto(scene: &Scene, grid: &OrthoGrid) -> RgbImage {
    let (w, h) = (grid.width, grid.height);
    let z0 = scene.world.ground_top() + START_ABOVE_GROUND_M;
    let down = Vector3::new(0.0, 0.0, -1.0);
    // The texture footprint of one pixel at the ground: gsd (radiance scales the angle by the distance).
    let pixel_angle = grid.gsd / START_ABOVE_GROUND_M;
    let mut rgb = vec![0u8; w as usize * h as usize * 3];
    rgb.par_chunks_mut(w as usize * 3).enumerate().for_each(|(row, line)| {
        for col in 0..w {
            let [e, n] = grid.centre(col, row as u32);
            let c = scene.tone(scene.radiance(&Vector3::new(e, n, z0), &down, pixel_angle));
            line[col as usize * 3..col as usize * 3 + 3].copy_from_slice(&c);
        }
    });
    RgbImage::from_raw(w, h, rgb).unwrap_or_default()
}

/// Samples per side of a terrain model's cell that [`terrain_model`] averages.
const TERRAIN_SAMPLES: u32 = 4;

/// The terrain model (DTM) of `grid`: per cell the mean ground height of 4 × 4 samples (kerbs averaged over
/// the cell, as a DTM interpolated from ground points has them), row-major from the north-west.
pub fn terrain_model(world: &World, grid: &OrthoGrid) -> Vec<f32> {
    let n = TERRAIN_SAMPLES;
    let mut heights = vec![0f32; grid.width as usize * grid.height as usize];
    heights.par_chunks_mut(grid.width as usize).enumerate().for_each(|(row, line)| {
        for (col, h) in line.iter_mut().enumerate() {
            let west = grid.west + col as f64 * grid.gsd;
            let north = grid.north - row as f64 * grid.gsd;
            let mut sum = 0.0;
            for i in 0..n {
                for j in 0..n {
                    let e = west + (f64::from(i) + 0.5) / f64::from(n) * grid.gsd;
                    let nn = north - (f64::from(j) + 0.5) / f64::from(n) * grid.gsd;
                    sum += world.ground_at(e, nn);
                }
            }
            *h = (sum / f64::from(n * n)) as f32;
        }
    });
    heights
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::{Preset, WorldConfig};

    #[test]
    fn pixels_sit_where_the_geotransform_says_crowns_show_where_trees_stand() {
        let world = World::generate(&WorldConfig::new(Preset::Tiny, 2)).unwrap();
        let scene = Scene::aerial(&world);
        let grid = OrthoGrid::covering(&scene, 0.5);
        let gt = grid.geotransform();
        let [e, n] = grid.centre(10, 20);
        assert!((e - (gt[0] + 10.5 * gt[1])).abs() < 1e-9 && (n - (gt[3] + 20.5 * gt[5])).abs() < 1e-9);
        // A 20 m window with a crown centre 3 m from its west and north edges: green there. A flipped row or
        // column axis would look 6 m from the crown centre, beyond its radius (2–3.5 m).
        let green = |c: [u8; 3]| c[1] > c[0] && c[1] > c[2];
        let mut checked = 0;
        for tree in world.poles.iter().filter(|p| p.crown > 0.0) {
            let c = tree.crown_center(world.pole_ground(tree.id));
            let sub = OrthoGrid { west: c.x - 3.0, north: c.y + 3.0, gsd: 0.1, width: 200, height: 200 };
            let img = render_orthophoto(&scene, &sub);
            assert!(green(img.get_pixel(30, 30).0), "crown of tree {} at {:?}", tree.id, img.get_pixel(30, 30));
            checked += 1;
            if checked == 3 {
                break;
            }
        }
        assert_eq!(checked, 3);
    }
}
