//! One aerial image as the registration sees it: a frame (pinhole + exterior orientation) or an orthophoto
//! (geotransform), with the projection of mapping points into it, its local orientation and pixel size at
//! the recording location (Jende et al. 2017 §3.6–3.7), windows around a point, and rays through its pixels.

use nalgebra::{Matrix2, Vector2};
use plumbline_geo::camera::{CameraModel, Pixel};
use plumbline_geo::{Point3, Vec3};
use plumbline_imaging::GrayImage;

use super::{AerialFrame, Orthophoto, Terrain};

/// A frame or an orthophoto.
#[derive(Clone, Copy, Debug)]
pub(crate) enum View<'a> {
    /// A frame image of the block.
    Frame(&'a AerialFrame),
    /// A georeferenced orthophoto.
    Ortho(&'a Orthophoto),
}

/// How the image lies around a ground point: pixel of the point, the heading of the image's up direction
/// (radians clockwise from grid north) and the ground size of a pixel (metres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct LocalGeometry {
    /// Full-image pixel of the ground point.
    pub pixel: [f64; 2],
    /// Heading of the image's −v direction on the ground.
    pub up_heading: f64,
    /// Ground sampling distance, metres per pixel (square root of the local area scale).
    pub gsd: f64,
}

/// A crop of an image: the pixels and the full-image position of its top-left corner.
#[derive(Clone, Debug)]
pub(crate) struct Window {
    /// The cropped pixels.
    pub image: GrayImage,
    /// Full-image column and row of the window's (0, 0).
    pub origin: [f64; 2],
}

impl<'a> View<'a> {
    /// The image id.
    pub fn id(&self) -> &'a str {
        match self {
            View::Frame(f) => &f.id,
            View::Ortho(o) => &o.id,
        }
    }

    /// The pixels held: the whole image, or the window of a frame that starts at [`View::origin`].
    pub fn image(&self) -> &'a GrayImage {
        match self {
            View::Frame(f) => &f.image,
            View::Ortho(o) => &o.image,
        }
    }

    /// Full-image column and row of the held pixels' (0, 0).
    pub fn origin(&self) -> [f64; 2] {
        match self {
            View::Frame(f) => [f.origin[0] as f64, f.origin[1] as f64],
            View::Ortho(_) => [0.0, 0.0],
        }
    }

    /// Full-image pixel of a mapping point (E, N, H); `None` behind the camera or off the model.
    pub fn project(&self, p: [f64; 3]) -> Option<[f64; 2]> {
        match self {
            View::Frame(f) => {
                let c = f.pose.inverse().transform_point(&Point3::new(p[0], p[1], p[2]));
                let px = f.camera.project(&(c - Point3::origin()))?;
                Some([px.u, px.v])
            }
            View::Ortho(o) => {
                let g = &o.geotransform;
                let m = Matrix2::new(g[1], g[2], g[4], g[5]).try_inverse()?;
                let uv = m * Vector2::new(p[0] - g[0], p[1] - g[3]);
                Some([uv.x, uv.y])
            }
        }
    }

    /// What makes the image unusable, if anything: a frame whose pixels reach beyond its camera's image.
    pub fn problem(&self) -> Option<String> {
        let View::Frame(f) = self else { return None };
        let (w, h) = (f.image.width(), f.image.height());
        let [c, r] = f.origin;
        let (cw, ch) = (f.camera.width as usize, f.camera.height as usize);
        let beyond = c.saturating_add(w) > cw || r.saturating_add(h) > ch;
        beyond.then(|| match f.origin {
            [0, 0] => format!("image {w}×{h} does not fit its camera {cw}×{ch}"),
            _ => format!("window {w}×{h} at column {c}, row {r} reaches beyond its camera {cw}×{ch}"),
        })
    }

    /// True when full-image `pixel` lies inside the held pixels with `margin` pixels to spare.
    pub fn contains(&self, pixel: [f64; 2], margin: f64) -> bool {
        let img = self.image();
        let [u, v] = self.held(pixel);
        let (w, h) = (img.width() as f64, img.height() as f64);
        u >= margin && v >= margin && u <= w - margin && v <= h - margin
    }

    /// A full-image pixel in the held pixels' coordinates.
    fn held(&self, pixel: [f64; 2]) -> [f64; 2] {
        let o = self.origin();
        [pixel[0] - o[0], pixel[1] - o[1]]
    }

    /// Local orientation and scale at a ground point, from the projections of 1 m steps east and north
    /// (Jende et al. 2017 §3.6: the MM patch is rotated into the aerial image's orientation).
    pub fn local_geometry(&self, p: [f64; 3]) -> Option<LocalGeometry> {
        let p0 = self.project(p)?;
        let pe = self.project([p[0] + 1.0, p[1], p[2]])?;
        let pn = self.project([p[0], p[1] + 1.0, p[2]])?;
        // J = ∂(u, v)/∂(E, N); the ground vector of image up (0, −1) is J⁻¹ (0, −1).
        let j = Matrix2::new(pe[0] - p0[0], pn[0] - p0[0], pe[1] - p0[1], pn[1] - p0[1]);
        let inv = j.try_inverse()?;
        let up = inv * Vector2::new(0.0, -1.0);
        let gsd = inv.determinant().abs().sqrt();
        (gsd.is_finite() && gsd > 0.0).then(|| LocalGeometry { pixel: p0, up_heading: up.x.atan2(up.y), gsd })
    }

    /// The window of half-size `half` pixels around full-image `centre` (clipped to the held pixels); `None`
    /// when less than a quarter of it lies inside.
    pub fn window(&self, centre: [f64; 2], half: usize) -> Option<Window> {
        let img = self.image();
        let (w, h) = (img.width() as i64, img.height() as i64);
        let [u, v] = self.held(centre);
        let (cc, cr) = (u.floor() as i64, v.floor() as i64);
        let half = half as i64;
        let (c0, r0) = ((cc - half).max(0), (cr - half).max(0));
        let (c1, r1) = ((cc + half + 1).min(w), (cr + half + 1).min(h));
        let (ww, wh) = (c1 - c0, r1 - r0);
        if ww <= 0 || wh <= 0 || 4 * ww * wh < (2 * half + 1).pow(2) {
            return None;
        }
        let (ww, wh, c0u, r0u) = (ww as usize, wh as usize, c0 as usize, r0 as usize);
        let image = GrayImage::from_fn(ww, wh, |c, r| img.get(c0u + c, r0u + r));
        let o = self.origin();
        Some(Window { image, origin: [o[0] + c0 as f64, o[1] + r0 as f64] })
    }

    /// The mapping-frame ray (origin, unit direction) through a full-image pixel of a frame; orthophotos
    /// have none (their pixels are looked up, not intersected).
    pub fn ray(&self, pixel: [f64; 2]) -> Option<([f64; 3], [f64; 3])> {
        let View::Frame(f) = self else { return None };
        let d: Vec3<_> = f.pose.rotation.apply(&f.camera.unproject(Pixel::new(pixel[0], pixel[1]))?);
        let o = f.pose.translation;
        Some(([o.x(), o.y(), o.z()], [d.x(), d.y(), d.z()]))
    }

    /// Where the ray through a full-image pixel meets the plane at `height` (E, N); an orthophoto pixel's
    /// mapping position. None when the ray runs parallel to the plane.
    pub fn ground(&self, pixel: [f64; 2], height: f64) -> Option<[f64; 2]> {
        if let View::Ortho(_) = self {
            return self.ortho_map(pixel);
        }
        let (o, d) = self.ray(pixel)?;
        if d[2].abs() < 1e-12 {
            return None;
        }
        let s = (height - o[2]) / d[2];
        Some([o[0] + s * d[0], o[1] + s * d[1]])
    }

    /// The mapping (E, N) of an orthophoto pixel.
    pub fn ortho_map(&self, pixel: [f64; 2]) -> Option<[f64; 2]> {
        let View::Ortho(o) = self else { return None };
        Some(apply_geotransform(&o.geotransform, pixel))
    }
}

/// E, N of continuous pixel (u, v) under a GDAL geotransform.
pub(crate) fn apply_geotransform(g: &[f64; 6], pixel: [f64; 2]) -> [f64; 2] {
    [g[0] + pixel[0] * g[1] + pixel[1] * g[2], g[3] + pixel[0] * g[4] + pixel[1] * g[5]]
}

impl Terrain {
    /// Bilinear terrain height at (E, N); `None` outside the grid or on no-data.
    pub fn height_at(&self, e: f64, n: f64) -> Option<f64> {
        let g = &self.geotransform;
        let m = Matrix2::new(g[1], g[2], g[4], g[5]).try_inverse()?;
        let uv = m * Vector2::new(e - g[0], n - g[3]);
        let (x, y) = (uv.x - 0.5, uv.y - 0.5);
        if self.heights.len() != self.width * self.height || self.width == 0 || self.height == 0 {
            return None;
        }
        let (x0, y0) = (x.floor().max(0.0), y.floor().max(0.0));
        if uv.x < 0.0 || uv.y < 0.0 || uv.x > self.width as f64 || uv.y > self.height as f64 {
            return None;
        }
        let (c0, r0) = ((x0 as usize).min(self.width - 1), (y0 as usize).min(self.height - 1));
        let (c1, r1) = ((c0 + 1).min(self.width - 1), (r0 + 1).min(self.height - 1));
        let (fx, fy) = ((x - x0).clamp(0.0, 1.0), (y - y0).clamp(0.0, 1.0));
        let at = |c: usize, r: usize| f64::from(self.heights[r * self.width + c]);
        let top = at(c0, r0) * (1.0 - fx) + at(c1, r0) * fx;
        let bottom = at(c0, r1) * (1.0 - fx) + at(c1, r1) * fx;
        let h = top * (1.0 - fy) + bottom * fy;
        h.is_finite().then_some(h)
    }
}
