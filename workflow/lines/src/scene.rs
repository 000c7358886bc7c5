//! Test support: synthetic ortho patches of a straight or curved road with anti-aliased paint, distractors
//! (sidewalk, car roof, arrow, repairs), seeded noise and an invalid vehicle disc.

use plumbline_imaging::ortho::GroundGrid;
use plumbline_imaging::{GrayImage, Mask};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::geometry::{add_scaled, cross, normal, sub, unit};

/// Fresh paint, worn paint and asphalt grey values.
pub(crate) const PAINT: f32 = 0.8;
pub(crate) const WORN: f32 = 0.525;
pub(crate) const ASPHALT: f32 = 0.25;

/// A straight road frame: x to the right of the driving direction, y along it, both metres.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Road {
    pub(crate) origin: [f64; 2],
    /// Driving direction, radians clockwise from grid north.
    pub(crate) heading: f64,
}

impl Road {
    pub(crate) fn map(&self, x: f64, y: f64) -> [f64; 2] {
        let (s, c) = self.heading.sin_cos();
        [self.origin[0] + x * c + y * s, self.origin[1] - x * s + y * c]
    }

    /// A stripe from road (x0, y0) to (x1, y1), in map coordinates.
    pub(crate) fn line(&self, x0: f64, y0: f64, x1: f64, y1: f64) -> Vec<[f64; 2]> {
        vec![self.map(x0, y0), self.map(x1, y1)]
    }

    /// An axis-aligned road rectangle as a map polygon.
    pub(crate) fn rect(&self, x0: f64, x1: f64, y0: f64, y1: f64) -> Vec<[f64; 2]> {
        vec![self.map(x0, y0), self.map(x1, y0), self.map(x1, y1), self.map(x0, y1)]
    }
}

/// Something painted on the patch, in map coordinates.
#[derive(Clone, Debug)]
pub(crate) enum Shape {
    /// A flat-ended stripe along a polyline.
    Stripe { line: Vec<[f64; 2]>, width: f64, value: f32 },
    /// A convex polygon.
    Polygon { corners: Vec<[f64; 2]>, value: f32 },
}

/// Render `shapes` (later over earlier) on asphalt at 4×4 supersampling, add Gaussian noise of σ `noise`
/// and blank a disc (map centre, radius) as invalid.
pub(crate) fn render(
    grid: &GroundGrid,
    shapes: &[Shape],
    noise: f32,
    seed: u64,
    disc: Option<([f64; 2], f64)>,
) -> (GrayImage, Mask) {
    const S: usize = 4;
    let (w, h) = (grid.width * S, grid.height * S);
    let mut hi = vec![ASPHALT; w * h];
    let mut fill = |corners: &[[f64; 2]], value: f32| {
        let px: Vec<[f64; 2]> = corners
            .iter()
            .map(|p| {
                let q = grid.to_pixel(p[0], p[1]);
                [q[0] * S as f64, q[1] * S as f64]
            })
            .collect();
        let lo = |k: usize| px.iter().map(|p| p[k]).fold(f64::INFINITY, f64::min).floor().max(0.0) as usize;
        let hi_ = |k: usize, n: usize| {
            (px.iter().map(|p| p[k]).fold(f64::NEG_INFINITY, f64::max).ceil().max(0.0) as usize).min(n)
        };
        let area: f64 = (0..px.len()).map(|i| cross(px[i], px[(i + 1) % px.len()])).sum();
        for r in lo(1)..hi_(1, h) {
            for c in lo(0)..hi_(0, w) {
                let p = [c as f64 + 0.5, r as f64 + 0.5];
                let inside =
                    (0..px.len()).all(|i| cross(sub(px[(i + 1) % px.len()], px[i]), sub(p, px[i])) * area >= 0.0);
                if inside {
                    hi[r * w + c] = value;
                }
            }
        }
    };
    for shape in shapes {
        match shape {
            Shape::Stripe { line, width, value } => {
                for seg in line.windows(2) {
                    let Some(t) = unit(sub(seg[1], seg[0])) else { continue };
                    let n = normal(t);
                    let hw = width / 2.0;
                    let quad = [
                        add_scaled(seg[0], n, hw),
                        add_scaled(seg[1], n, hw),
                        add_scaled(seg[1], n, -hw),
                        add_scaled(seg[0], n, -hw),
                    ];
                    fill(&quad, *value);
                }
            }
            Shape::Polygon { corners, value } => fill(corners, *value),
        }
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut data = vec![0.0f32; grid.width * grid.height];
    let mut valid = vec![true; grid.width * grid.height];
    for r in 0..grid.height {
        for c in 0..grid.width {
            let mut sum = 0.0;
            for rr in 0..S {
                sum += hi[(r * S + rr) * w + c * S..(r * S + rr) * w + c * S + S].iter().sum::<f32>();
            }
            // Box–Muller
            let (u1, u2): (f32, f32) = (rng.random_range(1e-7..1.0), rng.random_range(0.0..1.0));
            let g = (-2.0 * u1.ln()).sqrt() * (std::f32::consts::TAU * u2).cos();
            let i = r * grid.width + c;
            data[i] = sum / (S * S) as f32 + noise * g;
            if let Some((centre, radius)) = disc {
                let p = grid.to_map(c as f64 + 0.5, r as f64 + 0.5);
                if (p[0] - centre[0]).hypot(p[1] - centre[1]) < radius {
                    valid[i] = false;
                    data[i] = 0.0;
                }
            }
        }
    }
    (GrayImage::new(grid.width, grid.height, data).unwrap(), Mask::new(grid.width, grid.height, valid).unwrap())
}

/// Distractors in road coordinates: a sidewalk band, a car roof, an arrow, a dark repair and a shadow.
pub(crate) fn distractors(road: &Road, sidewalk_x: f64, roof: [f64; 2], arrow: [f64; 2]) -> Vec<Shape> {
    let [ax, ay] = arrow;
    vec![
        Shape::Polygon { corners: road.rect(roof[0] - 2.5, roof[0] - 1.3, roof[1] - 3.0, roof[1] + 1.0), value: 0.15 },
        Shape::Polygon { corners: road.rect(sidewalk_x, sidewalk_x + 6.0, -40.0, 40.0), value: 0.45 },
        Shape::Polygon { corners: road.rect(roof[0] - 0.9, roof[0] + 0.9, roof[1] - 2.0, roof[1] + 2.0), value: 0.85 },
        Shape::Polygon { corners: road.rect(ax - 0.15, ax + 0.15, ay, ay + 3.5), value: PAINT },
        Shape::Polygon {
            corners: vec![road.map(ax - 0.6, ay + 3.5), road.map(ax + 0.6, ay + 3.5), road.map(ax, ay + 5.0)],
            value: PAINT,
        },
        Shape::Polygon { corners: road.rect(ax - 1.0, ax + 0.2, ay - 3.0, ay - 1.5), value: 0.31 },
    ]
}
