//! Ortho-projection of panoramas onto the ground (Jende et al. 2017 §3.2) and rectification of pinhole images to
//! the road plane (Cazzaniga et al. 2007 §4.2), both by back-projection: every ground cell, given in mapping
//! coordinates, is projected into the image through the camera model and sampled bilinearly.

use nalgebra::{Matrix3, Vector3};
use plumbline_geo::camera::{CameraModel, Equirectangular, Pinhole, Pixel};
use plumbline_geo::dg::CameraMount;
use plumbline_geo::{Camera, MapFromBody, Vec3};
use rayon::prelude::*;

use crate::error::{ImagingError, require};
use crate::image::{GrayImage, ImagePart, Mask};

/// A raster on the ground: its centre in mapping coordinates, its ground sampling distance, its size, and
/// the direction its "up" (−v) points as a heading (radians clockwise from grid north; 0 = north-up).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GroundGrid {
    /// Easting and northing of the raster centre, metres.
    pub centre: [f64; 2],
    /// Ground sampling distance, metres per pixel (0.03 for MM↔MM, 0.12 for MM↔aerial: Jende et al. 2017 §3.2).
    pub gsd: f64,
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Heading of the raster's up direction, radians clockwise from grid north.
    pub up_heading: f64,
}

impl GroundGrid {
    /// Check and build a grid.
    pub fn new(centre: [f64; 2], gsd: f64, width: usize, height: usize, up_heading: f64) -> Result<Self, ImagingError> {
        require(centre.iter().all(|c| c.is_finite()), "centre", centre[0], "must be finite")?;
        require(gsd.is_finite() && gsd > 0.0, "gsd", gsd, "must be a positive ground distance in metres")?;
        require(width > 0 && height > 0, "width/height", width.min(height) as f64, "must be positive")?;
        require(up_heading.is_finite(), "up_heading", up_heading, "must be finite")?;
        Ok(Self { centre, gsd, width, height, up_heading })
    }

    /// The mapping (easting, northing) of continuous raster pixel (u, v).
    pub fn to_map(&self, u: f64, v: f64) -> [f64; 2] {
        let (s, c) = self.up_heading.sin_cos();
        let (right, up) = ((u - self.width as f64 / 2.0) * self.gsd, (self.height as f64 / 2.0 - v) * self.gsd);
        // right = (cos θ, −sin θ), up = (sin θ, cos θ) in (E, N) for a heading θ clockwise from north
        [self.centre[0] + right * c + up * s, self.centre[1] - right * s + up * c]
    }

    /// The continuous raster pixel (u, v) of a mapping (easting, northing).
    pub fn to_pixel(&self, e: f64, n: f64) -> [f64; 2] {
        let (s, c) = self.up_heading.sin_cos();
        let (de, dn) = (e - self.centre[0], n - self.centre[1]);
        let (right, up) = (de * c - dn * s, de * s + dn * c);
        [self.width as f64 / 2.0 + right / self.gsd, self.height as f64 / 2.0 - up / self.gsd]
    }

    /// The affine 3×3 matrix from raster (u, v, 1) to mapping (E, N, 1).
    pub fn map_from_pixel(&self) -> Matrix3<f64> {
        let (o, x, y) = (self.to_map(0.0, 0.0), self.to_map(1.0, 0.0), self.to_map(0.0, 1.0));
        Matrix3::new(x[0] - o[0], y[0] - o[0], o[0], x[1] - o[1], y[1] - o[1], o[1], 0.0, 0.0, 1.0)
    }
}

/// A camera model the ortho-projection can sample: says whether its u coordinate wraps around.
pub trait OrthoCamera: CameraModel + Sync {
    /// True for 360° panoramas, whose left and right edges meet.
    const WRAPS_U: bool;
}

impl OrthoCamera for Equirectangular {
    const WRAPS_U: bool = true;
}

impl OrthoCamera for Pinhole {
    const WRAPS_U: bool = false;
}

/// An ortho-image and the mask of cells that received a sample (not off-image, not on the vehicle).
#[derive(Clone, Debug)]
pub struct Ortho {
    /// The ground raster (0 where invalid).
    pub image: GrayImage,
    /// `true` where the cell was sampled.
    pub valid: Mask,
}

/// Everything that places an image in the mapping frame.
#[derive(Clone, Copy, Debug)]
pub struct Exposure<'a, C> {
    /// The camera model (its size must match the image).
    pub camera: &'a C,
    /// Lever arm and boresight.
    pub mount: &'a CameraMount,
    /// The vehicle pose at the exposure.
    pub pose: &'a MapFromBody,
    /// For a panorama stitched from a ring of cameras: where each sees from (`None`: one centre).
    pub sub_cameras: Option<&'a SubCameras>,
    /// A rolling shutter and the camera's motion during the readout (`None`: all rows at the pose's time).
    pub rolling: Option<RollingShutter>,
}

/// A rolling shutter: the image's rows are read out from the top one to the bottom one over `readout_s`,
/// the exposure's time (its pose) being the middle row's, while the camera moves at `velocity`. A ground
/// point imaged in row v is thus seen from the centre displaced by `velocity · row_time(v)`: at 10 m/s and a
/// 33 ms readout, ground 3–8 m from a panorama rig is imaged 3–8 cm behind where the pose's centre would
/// see it, along the track. The ortho-projection undoes it by projecting each ground point from the centre
/// at its row's time (the rotation during the readout is left out: a yaw rate of 0.3 rad/s turns 5 mrad).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RollingShutter {
    /// Seconds from the first row's readout to the last's.
    pub readout_s: f64,
    /// The camera's velocity in the mapping frame during the readout (east, north, up), m/s.
    pub velocity: [f64; 3],
}

impl RollingShutter {
    /// Seconds from the exposure's time to the readout of continuous row `v` (pixels from the top edge) of an
    /// image `height` rows high.
    pub fn row_time(&self, v: f64, height: u32) -> f64 {
        self.readout_s * (v / f64::from(height.max(1)) - 0.5)
    }

    /// How far the camera has moved from its centre at the exposure's time when row `v` is read, in the
    /// mapping frame, metres.
    fn displacement(&self, v: f64, height: u32) -> Vector3<f64> {
        Vector3::from(self.velocity) * self.row_time(v, height)
    }
}

/// A 360° panorama stitched from a ring of cameras around the horizon, each imaging an equal slice of the
/// columns (the first from column 0) from its own centre, `radius_m` out along its optical axis (the middle
/// column of its slice, on the horizon row), and stitched at infinity: a pixel's ray leaves its camera's
/// centre in the pixel's direction. A point near the rig is then seen off its central direction by up to
/// `radius_m` / range — for the ground 4–10 m away and a 10 cm rig a shift of the whole slice by up to
/// 10 cm in the ortho-image, different in each slice. The ortho-projection undoes it by projecting each
/// ground point from the centre of the camera whose slice its pixel falls in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SubCameras {
    /// Cameras in the ring (at least 1).
    pub count: u32,
    /// Distance of each camera's centre from the panorama's centre, metres.
    pub radius_m: f64,
}

impl SubCameras {
    /// The camera imaging column `u` of a panorama `width` pixels wide.
    pub fn slice(&self, u: f64, width: u32) -> usize {
        let n = self.count.max(1);
        let col = u.floor().rem_euclid(f64::from(width)) as u64;
        ((col * u64::from(n)) / u64::from(width.max(1))).min(u64::from(n) - 1) as usize
    }

    /// Each camera's centre in the panorama's camera frame (its axis on the horizon row times the radius).
    pub fn centres<C: CameraModel>(&self, camera: &C) -> Vec<Vector3<f64>> {
        let (n, w, h) = (self.count.max(1), f64::from(camera.width()), f64::from(camera.height()));
        (0..n)
            .map(|k| {
                let axis = Pixel::new((f64::from(k) + 0.5) * w / f64::from(n), h / 2.0);
                camera.unproject(axis).map_or(Vector3::zeros(), |d| d.v * self.radius_m)
            })
            .collect()
    }

    /// The pixel showing the camera-frame point `p` (relative to the panorama's centre): projected from the
    /// centre of the camera whose slice the pixel falls in. A point near a seam that neither camera's slice
    /// shows (stitched at infinity, near ground falls between the slices: 2 · radius · sin(π / count) /
    /// range of the circle per seam) gets the pixel its central direction projects to, on the seam, so the
    /// ortho-image stays whole; `None` when the point does not project.
    pub fn project<C: CameraModel>(&self, camera: &C, centres: &[Vector3<f64>], p: &Vector3<f64>) -> Option<Pixel> {
        let from = |k: usize| camera.project(&Vec3::<Camera>::from_vector(p - centres[k]));
        let central = camera.project(&Vec3::<Camera>::from_vector(*p))?;
        let mut k = self.slice(central.u, camera.width());
        for _ in 0..2 {
            let px = from(k)?;
            let seen_by = self.slice(px.u, camera.width());
            if seen_by == k {
                return Some(px);
            }
            k = seen_by;
        }
        Some(central)
    }
}

/// Back-project every cell of `grid` at ground height `height(e, n)` into `image` and sample it
/// bilinearly (Jende et al. 2017 §3.2). Cells whose bilinear footprint touches `vehicle_mask` (set = vehicle)
/// or leaves the image are invalid.
pub fn ortho_project<C: OrthoCamera>(
    image: &GrayImage,
    vehicle_mask: Option<&Mask>,
    exposure: &Exposure<'_, C>,
    grid: &GroundGrid,
    height: impl Fn(f64, f64) -> f64 + Sync,
) -> Result<Ortho, ImagingError> {
    let part = ImagePart::whole(exposure.camera.width(), exposure.camera.height());
    ortho_project_part(image, &part, vehicle_mask, exposure, grid, height)
}

/// [`ortho_project`] from an image holding only `part` of the camera's pixels; `vehicle_mask` stays at the
/// camera's full size. Cells that project outside the part are invalid.
pub fn ortho_project_part<C: OrthoCamera>(
    image: &GrayImage,
    part: &ImagePart,
    vehicle_mask: Option<&Mask>,
    exposure: &Exposure<'_, C>,
    grid: &GroundGrid,
    height: impl Fn(f64, f64) -> f64 + Sync,
) -> Result<Ortho, ImagingError> {
    let cam = exposure.camera;
    let (w, h) = (cam.width() as usize, cam.height() as usize);
    if part.full() != (cam.width(), cam.height()) {
        let (pw, ph) = part.full();
        return Err(ImagingError::Shape {
            what: "image part (must be of the camera's image)",
            width: pw as usize,
            height: ph as usize,
            len: w * h,
        });
    }
    if image.width() != part.width() || image.height() != part.height() {
        return Err(ImagingError::Shape {
            what: "image (must match the camera size, or the part of it held)",
            width: image.width(),
            height: image.height(),
            len: part.width() * part.height(),
        });
    }
    if let Some(m) = vehicle_mask.filter(|m| m.width() != w || m.height() != h) {
        return Err(ImagingError::Shape {
            what: "vehicle mask (must match the camera size)",
            width: m.width(),
            height: m.height(),
            len: w * h,
        });
    }
    // The camera pose once per image: a cell costs one matrix product before the camera model.
    let pose = exposure.mount.camera_pose(exposure.pose);
    let (to_camera, centre) = (pose.rotation.matrix().transpose(), pose.translation);
    let ring = exposure.sub_cameras.map(|r| (r, r.centres(cam)));
    let rows = cam.height();
    let samples: Vec<Option<f32>> = (0..grid.width * grid.height)
        .into_par_iter()
        .map(|i| {
            let [e, n] = grid.to_map((i % grid.width) as f64 + 0.5, (i / grid.width) as f64 + 0.5);
            let from_centre = Vector3::new(e - centre.x(), n - centre.y(), height(e, n) - centre.z());
            let project = |moved: Vector3<f64>| {
                let d = to_camera * (from_centre - moved);
                match &ring {
                    None => cam.project(&Vec3::<Camera>::new(d.x, d.y, d.z)),
                    Some((r, centres)) => r.project(cam, centres, &d),
                }
            };
            let mut px = project(Vector3::zeros())?;
            if let Some(shutter) = &exposure.rolling {
                // The row depends on the centre it is seen from and the centre on the row: two fixed-point
                // steps (the displacement is centimetres against metres of range).
                for _ in 0..2 {
                    px = project(shutter.displacement(px.v, rows))?;
                }
            }
            if vehicle_mask.is_some_and(|m| touches::<C>(m, px.u, px.v)) {
                return None;
            }
            let (u, v) = (px.u / f64::from(part.col_step()), px.v - f64::from(part.first_row()));
            sample::<C>(image, u, v)
        })
        .collect();
    let valid = Mask::new(grid.width, grid.height, samples.iter().map(Option::is_some).collect())?;
    let image = GrayImage::new(grid.width, grid.height, samples.into_iter().map(|s| s.unwrap_or(0.0)).collect())?;
    Ok(Ortho { image, valid })
}

/// The four pixels a bilinear sample at (u, v) of a `w` × `h` image reads: (c0, c1, r0, r1) and the
/// weights (fx, fy) of c1 and r1; `None` off the image. u wraps for panoramas.
fn footprint<C: OrthoCamera>(w: usize, h: usize, u: f64, v: f64) -> Option<([usize; 4], [f32; 2])> {
    let (w, h) = (w as isize, h as isize);
    let inside_u = C::WRAPS_U || (u >= 0.0 && u <= w as f64);
    if !(inside_u && v >= 0.0 && v <= h as f64 && u.is_finite()) {
        return None;
    }
    let (x, y) = (u - 0.5, v - 0.5);
    let (x0, y0) = (floor(x), floor(y));
    let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
    let col = |c: isize| if C::WRAPS_U { c.rem_euclid(w) } else { c.clamp(0, w - 1) } as usize;
    let row = |r: isize| r.clamp(0, h - 1) as usize;
    Some(([col(x0 as isize), col(x0 as isize + 1), row(y0 as isize), row(y0 as isize + 1)], [fx, fy]))
}

/// `x.floor()` without the library call that baseline x86-64 (no SSE4.1 rounding) makes for it: truncation
/// toward zero, one down for negative non-integers. Exact wherever an `i64` holds `x`; −0.0 gives +0.0.
fn floor(x: f64) -> f64 {
    if x.abs() < 4.0e18 {
        let t = x as i64 as f64;
        if t > x { t - 1.0 } else { t }
    } else {
        x.floor()
    }
}

/// Whether the bilinear footprint of (u, v) touches a set pixel of `mask`.
fn touches<C: OrthoCamera>(mask: &Mask, u: f64, v: f64) -> bool {
    footprint::<C>(mask.width(), mask.height(), u, v).is_some_and(|([c0, c1, r0, r1], _)| {
        mask.get(c0, r0) || mask.get(c1, r0) || mask.get(c0, r1) || mask.get(c1, r1)
    })
}

/// Bilinear sample at (u, v), wrapping u for panoramas; `None` off the image.
fn sample<C: OrthoCamera>(img: &GrayImage, u: f64, v: f64) -> Option<f32> {
    let ([c0, c1, r0, r1], [fx, fy]) = footprint::<C>(img.width(), img.height(), u, v)?;
    let top = img.get(c0, r0) * (1.0 - fx) + img.get(c1, r0) * fx;
    let bottom = img.get(c0, r1) * (1.0 - fx) + img.get(c1, r1) * fx;
    Some(top * (1.0 - fy) + bottom * fy)
}

/// The homography from raster pixels of `grid` on the plane z = `height` to the ideal (undistorted)
/// pixels of a pinhole camera: H = K · R_Cᵀ · [g1, g2, g0 − C] (Cazzaniga et al. 2007 §4.2). Exact for K1 = K2 = 0;
/// with distortion, [`ortho_project`] applies the full camera model instead.
pub fn plane_homography(exposure: &Exposure<'_, Pinhole>, grid: &GroundGrid, height: f64) -> Matrix3<f64> {
    let cam = exposure.camera;
    let k = Matrix3::new(cam.fx, 0.0, cam.cx, 0.0, cam.fy, cam.cy, 0.0, 0.0, 1.0);
    let pose = exposure.mount.camera_pose(exposure.pose);
    let a = grid.map_from_pixel();
    let c = pose.translation;
    let m = Matrix3::from_columns(&[
        Vector3::new(a[(0, 0)], a[(1, 0)], 0.0),
        Vector3::new(a[(0, 1)], a[(1, 1)], 0.0),
        Vector3::new(a[(0, 2)] - c.x(), a[(1, 2)] - c.y(), height - c.z()),
    ]);
    let h = k * pose.rotation.matrix().transpose() * m;
    if h[(2, 2)].abs() > 1e-15 { h / h[(2, 2)] } else { h }
}

#[cfg(test)]
mod tests;
