//! Camera models: equirectangular 360×180 panoramas and pinhole cameras with radial distortion K1, K2.
//!
//! Pixel coordinates are continuous with (0, 0) at the top-left corner of the top-left pixel, u to the right
//! and v down, so the centre of pixel (col, row) is (col + 0.5, row + 0.5). Directions are in the
//! [`Camera`] frame (x right, y down, z along the viewing direction).

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::frames::{Camera, Vec3};

/// A continuous pixel position.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Pixel {
    /// Column coordinate, to the right.
    pub u: f64,
    /// Row coordinate, down.
    pub v: f64,
}

impl Pixel {
    /// Build a pixel position.
    pub fn new(u: f64, v: f64) -> Self {
        Self { u, v }
    }
}

/// What every camera model offers.
pub trait CameraModel {
    /// Image width in pixels.
    fn width(&self) -> u32;
    /// Image height in pixels.
    fn height(&self) -> u32;
    /// The pixel a camera-frame direction images to, or `None` when it does not image (behind a pinhole).
    fn project(&self, direction: &Vec3<Camera>) -> Option<Pixel>;
    /// The unit direction of the ray through a pixel, or `None` when no ray images there.
    fn unproject(&self, pixel: Pixel) -> Option<Vec3<Camera>>;
    /// True when the pixel lies on the image.
    fn contains(&self, p: Pixel) -> bool {
        p.u >= 0.0 && p.v >= 0.0 && p.u < f64::from(self.width()) && p.v < f64::from(self.height())
    }
}

/// Errors building a camera model.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CameraError {
    /// A parameter is out of its domain.
    #[error("camera parameter `{field}` = {value}: {reason}")]
    Invalid { field: &'static str, value: f64, reason: &'static str },
}

fn require(ok: bool, field: &'static str, value: f64, reason: &'static str) -> Result<(), CameraError> {
    if ok { Ok(()) } else { Err(CameraError::Invalid { field, value, reason }) }
}

/// A full-sphere equirectangular panorama: longitude along u (centre column = +z, right = +x),
/// latitude along v (top row = up = −y).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Equirectangular {
    /// Width in pixels (360°).
    pub width: u32,
    /// Height in pixels (180°).
    pub height: u32,
}

impl Equirectangular {
    /// A panorama of the given size; both dimensions must be positive.
    pub fn new(width: u32, height: u32) -> Result<Self, CameraError> {
        require(width > 0, "width", f64::from(width), "must be positive")?;
        require(height > 0, "height", f64::from(height), "must be positive")?;
        Ok(Self { width, height })
    }
}

impl CameraModel for Equirectangular {
    fn width(&self) -> u32 {
        self.width
    }
    fn height(&self) -> u32 {
        self.height
    }

    fn project(&self, d: &Vec3<Camera>) -> Option<Pixel> {
        // `hypot` only where the squares overflow: its guard costs a library call per pixel.
        let squares = (d.x() * d.x() + d.z() * d.z()).sqrt();
        let horizontal = if squares.is_finite() { squares } else { d.x().hypot(d.z()) };
        if !(d.is_finite() && (horizontal > 0.0 || d.y() != 0.0)) {
            return None;
        }
        let longitude = d.x().atan2(d.z());
        let latitude = (-d.y()).atan2(horizontal);
        let w = f64::from(self.width);
        let mut u = (longitude / std::f64::consts::TAU + 0.5) * w;
        if u >= w {
            u -= w;
        }
        let v = (0.5 - latitude / std::f64::consts::PI) * f64::from(self.height);
        Some(Pixel { u, v })
    }

    fn unproject(&self, p: Pixel) -> Option<Vec3<Camera>> {
        if !(p.u.is_finite() && p.v.is_finite()) {
            return None;
        }
        let longitude = (p.u / f64::from(self.width) - 0.5) * std::f64::consts::TAU;
        let latitude = (0.5 - p.v / f64::from(self.height)) * std::f64::consts::PI;
        let (sl, cl) = longitude.sin_cos();
        let (sp, cp) = latitude.sin_cos();
        Some(Vec3::new(cp * sl, -sp, cp * cl))
    }
}

/// A pinhole camera with radial distortion applied to normalised coordinates:
/// (x_d, y_d) = (x, y) · (1 + K1 r² + K2 r⁴), r² = x² + y², x = X/Z, y = Y/Z; then u = fx x_d + cx, v = fy y_d + cy.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Pinhole {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Focal length along u, pixels.
    pub fx: f64,
    /// Focal length along v, pixels.
    pub fy: f64,
    /// Principal point u, pixels.
    pub cx: f64,
    /// Principal point v, pixels.
    pub cy: f64,
    /// Radial coefficient of r² (dimensionless, normalised coordinates).
    pub k1: f64,
    /// Radial coefficient of r⁴ (dimensionless, normalised coordinates).
    pub k2: f64,
    /// Largest normalised undistorted radius that images inside the frame (cached, for inversion).
    #[serde(skip)]
    #[schemars(skip)]
    r_max: f64,
}

/// Interior orientation in the metric form of Grejner-Brzezinska and Toth (2000), Table 2.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct MetricInterior {
    /// Principal distance c, millimetres.
    pub focal_mm: f64,
    /// Principal point offset from the image centre, x to the right, millimetres.
    pub xp_mm: f64,
    /// Principal point offset from the image centre, y up, millimetres.
    pub yp_mm: f64,
    /// Radial K1, mm⁻² (radius in millimetres).
    pub k1: f64,
    /// Radial K2, mm⁻⁴.
    pub k2: f64,
    /// Pixel pitch, millimetres.
    pub pixel_mm: f64,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

impl Pinhole {
    /// Build and check the model: positive focal lengths, and a distortion that is monotonic over the image
    /// (otherwise pixels would have two rays and no unique inverse).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        width: u32,
        height: u32,
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        k1: f64,
        k2: f64,
    ) -> Result<Self, CameraError> {
        require(width > 0 && height > 0, "width/height", f64::from(width.min(height)), "must be positive")?;
        require(fx.is_finite() && fx > 0.0, "fx", fx, "must be a positive focal length in pixels")?;
        require(fy.is_finite() && fy > 0.0, "fy", fy, "must be a positive focal length in pixels")?;
        require(cx.is_finite(), "cx", cx, "must be finite")?;
        require(cy.is_finite(), "cy", cy, "must be finite")?;
        require(k1.is_finite(), "k1", k1, "must be finite")?;
        require(k2.is_finite(), "k2", k2, "must be finite")?;
        let mut cam = Self { width, height, fx, fy, cx, cy, k1, k2, r_max: 0.0 };
        let rd_corner = cam.max_distorted_radius();
        cam.r_max = cam.undistort_radius_bracket(rd_corner).ok_or(CameraError::Invalid {
            field: "k1/k2",
            value: k1,
            reason: "radial distortion folds over inside the image (not monotonic)",
        })?;
        Ok(cam)
    }

    /// Convert a metric calibration (Grejner-Brzezinska and Toth 2000, Table 2: c, xp, yp, K1, K2 in millimetres) to
    /// pixels and normalised coefficients: K1_n = K1 · c², K2_n = K2 · c⁴. The metric K1/K2 are taken as the forward
    /// (ideal → image) model; a calibration in the correction form agrees with it to first order.
    pub fn from_metric(m: &MetricInterior) -> Result<Self, CameraError> {
        require(m.pixel_mm.is_finite() && m.pixel_mm > 0.0, "pixel_mm", m.pixel_mm, "must be positive")?;
        let f = m.focal_mm / m.pixel_mm;
        let cx = f64::from(m.width) / 2.0 + m.xp_mm / m.pixel_mm;
        let cy = f64::from(m.height) / 2.0 - m.yp_mm / m.pixel_mm;
        let c2 = m.focal_mm * m.focal_mm;
        Self::new(m.width, m.height, f, f, cx, cy, m.k1 * c2, m.k2 * c2 * c2)
    }

    fn distortion(&self, r2: f64) -> f64 {
        1.0 + self.k1 * r2 + self.k2 * r2 * r2
    }

    /// Largest distorted normalised radius over the image corners.
    fn max_distorted_radius(&self) -> f64 {
        let (w, h) = (f64::from(self.width), f64::from(self.height));
        [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)]
            .iter()
            .map(|(u, v)| ((u - self.cx) / self.fx).hypot((v - self.cy) / self.fy))
            .fold(0.0, f64::max)
    }

    /// Undistorted radius r with r·D(r²) = rd on the monotonic branch; `None` if the branch ends first.
    fn undistort_radius_bracket(&self, rd: f64) -> Option<f64> {
        // Walk outward on the monotonic branch until r·D(r²) passes rd, then bisect: robust for any K1, K2.
        let f = |r: f64| r * self.distortion(r * r);
        let df = |r: f64| 1.0 + 3.0 * self.k1 * r * r + 5.0 * self.k2 * r.powi(4);
        let (mut lo, mut hi) = (0.0, rd.max(1e-12));
        while f(hi) < rd {
            if df(hi) <= 0.0 || hi > 1e6 {
                return None;
            }
            lo = hi;
            hi *= 1.5;
        }
        if (0..=200).any(|i| df(lo + (hi - lo) * f64::from(i) / 200.0) <= 0.0) {
            return None;
        }
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if f(mid) < rd { lo = mid } else { hi = mid }
        }
        Some(0.5 * (lo + hi))
    }

    /// Undistorted radius for a distorted one, by Newton from a good start (falls back to bisection).
    fn undistort_radius(&self, rd: f64) -> Option<f64> {
        let mut r = rd;
        for _ in 0..30 {
            let d = self.distortion(r * r);
            let g = r * d - rd;
            let dg = 1.0 + 3.0 * self.k1 * r * r + 5.0 * self.k2 * r.powi(4);
            if dg <= 0.0 {
                return self.undistort_radius_bracket(rd);
            }
            let step = g / dg;
            r -= step;
            if step.abs() < 1e-15 * (1.0 + r.abs()) {
                return Some(r);
            }
        }
        self.undistort_radius_bracket(rd)
    }
}

impl CameraModel for Pinhole {
    fn width(&self) -> u32 {
        self.width
    }
    fn height(&self) -> u32 {
        self.height
    }

    fn project(&self, d: &Vec3<Camera>) -> Option<Pixel> {
        if !(d.is_finite() && d.z() > 0.0) {
            return None;
        }
        let (x, y) = (d.x() / d.z(), d.y() / d.z());
        let r2 = x * x + y * y;
        // Beyond the monotonic branch the model is meaningless: such rays do not image.
        if r2 > (self.r_max * 1.5).powi(2) {
            return None;
        }
        let s = self.distortion(r2);
        Some(Pixel { u: self.fx * x * s + self.cx, v: self.fy * y * s + self.cy })
    }

    fn unproject(&self, p: Pixel) -> Option<Vec3<Camera>> {
        if !(p.u.is_finite() && p.v.is_finite()) {
            return None;
        }
        let (xd, yd) = ((p.u - self.cx) / self.fx, (p.v - self.cy) / self.fy);
        let rd = xd.hypot(yd);
        let scale = if rd > 0.0 { self.undistort_radius(rd)? / rd } else { 1.0 };
        Vec3::from_vector(Vector3::new(xd * scale, yd * scale, 1.0)).normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Grejner-Brzezinska and Toth 2000, Table 2, calibration 1 (BigShot 4K×4K, 15 µm pixels).
    fn bigshot() -> Pinhole {
        Pinhole::from_metric(&MetricInterior {
            focal_mm: 51.568,
            xp_mm: 0.314,
            yp_mm: 0.112,
            k1: -2.77e-5,
            k2: 1.44e-8,
            pixel_mm: 0.015,
            width: 4096,
            height: 4096,
        })
        .unwrap()
    }

    fn sweep(width: u32, height: u32, n: usize, seed: u64) -> Vec<Pixel> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let (w, h) = (f64::from(width), f64::from(height));
        let mut out: Vec<Pixel> =
            (0..n).map(|_| Pixel::new(rng.random::<f64>() * w, rng.random::<f64>() * h)).collect();
        out.extend([Pixel::new(0.0, 0.0), Pixel::new(w - 1e-9, h - 1e-9), Pixel::new(0.0, h - 1e-9)]);
        out
    }

    #[test]
    fn equirectangular_axes_follow_the_convention() {
        let cam = Equirectangular::new(2048, 1024).unwrap();
        let check = |d: [f64; 3], u: f64, v: f64| {
            let p = cam.project(&Vec3::new(d[0], d[1], d[2])).unwrap();
            assert!((p.u - u).abs() < 1e-9 && (p.v - v).abs() < 1e-9, "{d:?} -> {p:?}");
        };
        check([0.0, 0.0, 1.0], 1024.0, 512.0); // forward: centre
        check([1.0, 0.0, 0.0], 1536.0, 512.0); // right: three quarters across
        check([-1.0, 0.0, 0.0], 512.0, 512.0); // left
        check([0.0, -1.0, 0.0], 1024.0, 0.0); // up: top row
        check([0.0, 0.0, -1.0], 0.0, 512.0); // backward: the seam
    }

    #[test]
    fn equirectangular_round_trip_over_the_whole_image() {
        let cam = Equirectangular::new(8192, 4096).unwrap();
        for p in sweep(8192, 4096, 20_000, 11) {
            let d = cam.unproject(p).unwrap();
            assert!((d.norm() - 1.0).abs() < 1e-12);
            let q = cam.project(&d).unwrap();
            let du = (q.u - p.u).abs();
            let du = du.min(8192.0 - du); // the seam wraps
            // Near the poles longitude is ill-conditioned in u but the direction is still exact.
            let back = cam.unproject(q).unwrap();
            assert!((back - d).norm() < 1e-9, "{p:?} -> {q:?}");
            if (p.v - 2048.0).abs() < 2000.0 {
                assert!(du < 1e-6 && (q.v - p.v).abs() < 1e-6, "{p:?} -> {q:?}");
            }
        }
    }

    #[test]
    fn pinhole_round_trip_over_the_whole_image() {
        let cam = bigshot();
        for p in sweep(4096, 4096, 20_000, 12) {
            let d = cam.unproject(p).unwrap();
            let q = cam.project(&d).unwrap();
            assert!((q.u - p.u).abs() < 1e-6 && (q.v - p.v).abs() < 1e-6, "{p:?} -> {q:?}");
        }
    }

    #[test]
    fn pinhole_distortion_pulls_corners_inward_for_negative_k1() {
        let cam = bigshot();
        let ideal = Pinhole::new(4096, 4096, cam.fx, cam.fy, cam.cx, cam.cy, 0.0, 0.0).unwrap();
        let d = Vec3::<Camera>::new(0.5, 0.5, 1.2);
        let (pd, pi) = (cam.project(&d).unwrap(), ideal.project(&d).unwrap());
        assert!((pd.u - cam.cx) < (pi.u - cam.cx), "barrel distortion must shrink the radius");
        // Principal point from Grejner-Brzezinska and Toth 2000: +0.314 mm right, +0.112 mm up
        // = 20.9 px right, 7.5 px up.
        assert!((cam.cx - (2048.0 + 0.314 / 0.015)).abs() < 1e-9);
        assert!((cam.cy - (2048.0 - 0.112 / 0.015)).abs() < 1e-9);
    }

    #[test]
    fn pinhole_rejects_folding_distortion_and_bad_focal() {
        assert!(Pinhole::new(1000, 1000, 500.0, 500.0, 500.0, 500.0, -0.6, 0.0).is_err());
        assert!(Pinhole::new(1000, 1000, -500.0, 500.0, 500.0, 500.0, 0.0, 0.0).is_err());
        assert!(
            Pinhole::new(1000, 1000, 500.0, 500.0, 500.0, 500.0, 0.0, 0.0)
                .unwrap()
                .project(&Vec3::new(0.0, 0.0, -1.0))
                .is_none()
        );
    }
}
