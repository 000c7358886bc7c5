//! A static street scene as a mobile laser scanner delivers it, with the truth of its stems: ground with
//! slope, tree trunks (taper, lean, crown), poles (with a lamp arm), a facade, a parked car and a bush,
//! scanned from a straight drive. Each surface is sampled where it faces the drive line (one side of a
//! stem, as one pass sees it), and every point is moved along its line of sight to the nearest scanner
//! position by the range noise. Occlusion between objects is not modelled.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::observations::normal;

/// A stem of the scene and its truth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StemTruth {
    /// Where the stem meets the ground (easting, northing), m.
    pub base: [f64; 2],
    /// Diameter at 1.3 m above ground, m.
    pub diameter_m: f64,
    /// Loss of diameter per metre of height, m/m.
    pub taper: f64,
    /// Horizontal offset per metre of height (east, north), m/m.
    pub lean: [f64; 2],
    /// Height of the stem above ground, m.
    pub height_m: f64,
    /// Whether a crown sits on it (a tree) or a lamp arm (a pole).
    pub crown: bool,
}

impl StemTruth {
    /// The stem's centre at `h` metres above ground.
    pub fn centre_at(&self, h: f64) -> [f64; 2] {
        [self.base[0] + self.lean[0] * h, self.base[1] + self.lean[1] * h]
    }
}

/// The scene's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScanScene {
    /// Origin of the scene (easting, northing, ground height at the origin), m.
    pub origin: [f64; 3],
    /// Length of the drive along north, m.
    pub length_m: f64,
    /// Height of the scanner above ground, m.
    pub scanner_height_m: f64,
    /// Range noise σ, m.
    pub range_sigma_m: f64,
    /// Surface sampling step, m.
    pub spacing_m: f64,
    /// Ground slope (east, north), m/m.
    pub slope: [f64; 2],
}

impl Default for ScanScene {
    fn default() -> Self {
        Self {
            origin: [512_000.0, 5_403_000.0, 100.0],
            length_m: 60.0,
            scanner_height_m: 2.2,
            range_sigma_m: 0.01,
            spacing_m: 0.02,
            slope: [0.02, 0.01],
        }
    }
}

/// The stems of [`scan_scene`], relative to the scene origin (add `origin` for map coordinates).
pub fn scene_stems() -> Vec<StemTruth> {
    vec![
        StemTruth { base: [4.0, 10.0], diameter_m: 0.40, taper: 0.01, lean: [0.03, 0.0], height_m: 4.0, crown: true },
        StemTruth { base: [-5.0, 22.0], diameter_m: 0.25, taper: 0.01, lean: [0.0, -0.02], height_m: 3.0, crown: true },
        StemTruth { base: [3.5, 30.0], diameter_m: 0.12, taper: 0.0, lean: [0.0, 0.0], height_m: 6.0, crown: false },
        StemTruth { base: [-3.5, 45.0], diameter_m: 0.08, taper: 0.0, lean: [0.01, 0.01], height_m: 3.0, crown: false },
    ]
}

/// The scene's points (map coordinates) and its stems (map coordinates), seeded.
pub fn scan_scene(scene: &ScanScene, seed: u64) -> (Vec<[f64; 3]>, Vec<StemTruth>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let [ox, oy, oz] = scene.origin;
    let ground = |x: f64, y: f64| oz + scene.slope[0] * x + scene.slope[1] * y;
    let step = scene.spacing_m;
    let mut local: Vec<[f64; 3]> = Vec::new();
    // Ground: a 30 m wide corridor, sampled coarser (it dominates any real cloud too).
    let g = 0.1;
    let (nx, ny) = ((30.0 / g) as i64, (scene.length_m / g) as i64);
    for i in 0..=nx {
        for j in 0..=ny {
            let (x, y) = (-15.0 + i as f64 * g, j as f64 * g);
            local.push([x, y, ground(x, y) - oz]);
        }
    }
    let stems = scene_stems();
    for s in &stems {
        let gz = ground(s.base[0], s.base[1]) - oz;
        // Visible half: the directions within ±80° of the one toward the drive line (x = 0).
        let toward = if s.base[0] > 0.0 { std::f64::consts::PI } else { 0.0 };
        let mut h = 0.0;
        while h <= s.height_m {
            let r = 0.5 * (s.diameter_m - s.taper * (h - 1.3));
            let c = s.centre_at(h);
            let n = ((160f64.to_radians() * r) / step).ceil().max(4.0) as i64;
            for k in 0..=n {
                let a = toward + (-80.0 + 160.0 * k as f64 / n as f64).to_radians();
                local.push([c[0] + r * a.cos(), c[1] + r * a.sin(), gz + h]);
            }
            h += step;
        }
        let top = s.centre_at(s.height_m);
        if s.crown {
            // A crown: 4000 points in an ellipsoid 3 m across and 3 m high above the stem.
            for _ in 0..4000 {
                let (u, v, w): (f64, f64, f64) = (rng.random(), rng.random(), rng.random());
                let a = std::f64::consts::TAU * u;
                let rr = 1.5 * v.sqrt();
                local.push([top[0] + rr * a.cos(), top[1] + rr * a.sin(), gz + s.height_m + 3.0 * w]);
            }
        } else {
            // A lamp arm toward the road, 1.2 m long.
            let dir = if s.base[0] > 0.0 { -1.0 } else { 1.0 };
            let mut d = 0.0;
            while d <= 1.2 {
                local.push([top[0] + dir * d, top[1], gz + s.height_m]);
                d += step;
            }
        }
    }
    // A facade 12 m east of the drive, 8 m high (sampled 10 cm).
    let mut y = 0.0;
    while y <= scene.length_m {
        let mut z = 0.0;
        while z <= 8.0 {
            local.push([12.0, y, ground(12.0, y) - oz + z]);
            z += 0.1;
        }
        y += 0.1;
    }
    // A parked car west of the drive: its side facing the road and its roof.
    let (cx, cy) = (-3.0, 15.0);
    let mut y = cy;
    while y <= cy + 4.5 {
        let mut z = 0.3;
        while z <= 1.5 {
            local.push([cx, y, ground(cx, y) - oz + z]);
            z += step * 2.0;
        }
        let mut x = cx - 1.8;
        while x <= cx {
            local.push([x, y, ground(x, y) - oz + 1.5]);
            x += step * 2.0;
        }
        y += step * 2.0;
    }
    // A bush: 3000 points in a 1.2 m blob up to 1.6 m.
    let (bx, by) = (5.0, 38.0);
    for _ in 0..3000 {
        let (u, v, w): (f64, f64, f64) = (rng.random(), rng.random(), rng.random());
        let a = std::f64::consts::TAU * u;
        let rr = 0.6 * v.sqrt();
        local.push([bx + rr * a.cos(), by + rr * a.sin(), ground(bx, by) - oz + 0.1 + 1.5 * w]);
    }
    // Range noise along the line of sight from the nearest scanner position (0, y, scanner height).
    let points = local
        .into_iter()
        .map(|p| {
            let s = [0.0, p[1], ground(0.0, p[1]) - oz + scene.scanner_height_m];
            let d = [p[0] - s[0], p[1] - s[1], p[2] - s[2]];
            let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().max(1e-9);
            let e = scene.range_sigma_m * normal(&mut rng);
            [ox + p[0] + e * d[0] / n, oy + p[1] + e * d[1] / n, oz + p[2] + e * d[2] / n]
        })
        .collect();
    let stems = stems.into_iter().map(|s| StemTruth { base: [ox + s.base[0], oy + s.base[1]], ..s }).collect();
    (points, stems)
}
