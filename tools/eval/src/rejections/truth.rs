//! The simulated truth of a campaign written by `plumbline simulate`: the true body pose at every panorama's
//! exposure (`truth/images.csv`), the surface under every panorama pixel (`truth/pixels/{id}_range.png`,
//! `_class.png`) and the DG fault intervals (`truth/dg_errors.csv`), as `plumbline-eval rejections` reads it.

use std::collections::HashMap;

use nalgebra::{Matrix3, SymmetricEigen, Vector3};
use plumbline_geo::camera::{CameraModel, Equirectangular, Pixel};
use plumbline_geo::dg::CameraMount;
use plumbline_geo::metrics::quantile_sorted;
use plumbline_geo::{Attitude, MapFromBody, MapFromCamera, Point3};

/// Surface classes of `_class.png` (`plumbline_synth::render::SurfaceClass`).
pub const CLASSES: [&str; 9] = ["none", "ground", "facade", "roof", "pole", "crown", "car", "vehicle", "pedestrian"];

/// One panorama's true pose.
pub struct TrueImage {
    pub id: String,
    pub time: f64,
    pub body: MapFromBody,
}

/// The surface under each pixel of one panorama: range along the pixel-centre ray (mm, 0 = none) and class.
struct Pixels {
    width: u32,
    height: u32,
    range_mm: Vec<u16>,
    class: Vec<u8>,
}

/// Where an observed camera-frame direction of a panorama meets the true surface.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// The mapping-frame point.
    pub point: Vector3<f64>,
    /// Its surface class (index into [`CLASSES`]).
    pub class: u8,
}

/// The truth of one simulated campaign.
pub struct Truth {
    dir: String,
    images: Vec<TrueImage>,
    /// DG fault intervals (start, end, kind).
    pub faults: Vec<(f64, f64, String)>,
    pixels: HashMap<String, Option<Pixels>>,
    camera: Equirectangular,
    mount: CameraMount,
}

/// Rows of a CSV file with a header, as maps by column name.
pub fn csv_rows(path: &str) -> Vec<HashMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap_or_default().split(',').map(str::to_owned).collect();
    lines.map(|l| header.iter().cloned().zip(l.split(',').map(str::to_owned)).collect()).collect()
}

fn num(row: &HashMap<String, String>, key: &str) -> f64 {
    row.get(key).and_then(|v| v.parse().ok()).unwrap_or_else(|| panic!("column {key} missing or not a number"))
}

impl Truth {
    /// Read `dir/truth/…` for panoramas of `camera` on `mount`.
    pub fn load(dir: &str, camera: Equirectangular, mount: CameraMount) -> Self {
        let images = csv_rows(&format!("{dir}/truth/images.csv"))
            .iter()
            .map(|r| {
                let attitude = Attitude::from_degrees(num(r, "roll_deg"), num(r, "pitch_deg"), num(r, "heading_deg"));
                let position = Point3::new(num(r, "easting"), num(r, "northing"), num(r, "height"));
                TrueImage {
                    id: r["image_id"].clone(),
                    time: num(r, "time"),
                    body: MapFromBody::new(attitude.to_rotation(), position),
                }
            })
            .collect();
        let faults = fault_intervals(&csv_rows(&format!("{dir}/truth/dg_errors.csv")));
        Self { dir: dir.to_owned(), images, faults, pixels: HashMap::new(), camera, mount }
    }

    /// The panorama exposed at `t` (within 1 ms).
    pub fn image_at(&self, t: f64) -> Option<&TrueImage> {
        self.images.iter().find(|i| (i.time - t).abs() < 1e-3)
    }

    /// The true camera pose of the panorama exposed at `t`.
    pub fn camera_at(&self, t: f64) -> Option<MapFromCamera> {
        self.image_at(t).map(|i| self.mount.camera_pose(&i.body))
    }

    /// Where the camera-frame `direction` of the panorama exposed at `t` meets the true surface: the ray
    /// intersected with the plane fitted to the surface points of the 3 × 3 pixels around it that share the
    /// centre pixel's class (exact on the flat ground and on facades; the pixel-centre range otherwise).
    pub fn hit(&mut self, t: f64, direction: [f64; 3]) -> Option<Hit> {
        let pose = self.camera_at(t)?;
        let id = self.image_at(t)?.id.clone();
        let d = Vector3::from(direction).normalize();
        let px = self.camera.project(&plumbline_geo::Vec3::new(d.x, d.y, d.z))?;
        let (camera, dir) = (self.camera, self.dir.clone());
        let pixels = self.pixels.entry(id.clone()).or_insert_with(|| Pixels::load(&dir, &id)).as_ref()?;
        let (col, row) = (px.u.floor() as i64, px.v.floor() as i64);
        let (centre, class) = pixels.point(&camera, &pose, col, row)?;
        let mut near = Vec::new();
        for (dc, dr) in (-1..=1).flat_map(|a| (-1..=1).map(move |b| (a, b))) {
            if let Some((p, c)) = pixels.point(&camera, &pose, col + dc, row + dr) {
                (c == class).then(|| near.push(p));
            }
        }
        let origin = pose.translation.p;
        let ray = pose.rotation.matrix() * d;
        let point = plane_hit(&near, origin, ray).filter(|p| (p - centre).norm() < 0.5).unwrap_or(centre);
        Some(Hit { point, class })
    }

    /// The check of the truth itself: the true point under each tie's first ray, projected into its second
    /// panorama with the true pose and looked up again, must come back (unless something hides it there).
    pub fn self_check(&mut self, merged: &plumbline_adjuster::Merged) {
        let mut gaps = Vec::new();
        for tie in merged.observations.ties.iter().filter(|t| t.rays.len() > 1) {
            let (a, b) = (&tie.rays[0], &tie.rays[1]);
            let (Some(hit), Some(pose)) = (self.hit(a.time, a.direction), self.camera_at(b.time)) else { continue };
            let d = pose.rotation.matrix().transpose() * (hit.point - pose.translation.p);
            if let Some(back) = self.hit(b.time, [d.x, d.y, d.z]) {
                gaps.push((back.point - hit.point).norm());
            }
        }
        gaps.sort_by(f64::total_cmp);
        let q = |p: f64| quantile_sorted(&gaps, p).unwrap_or(f64::NAN);
        let near = gaps.iter().filter(|g| **g < 0.02).count();
        println!(
            "truth self-check: first ray's true point re-read through the second panorama: {} ties, median gap {:.4} m, \
             95 % {:.3} m, {near} within 2 cm\n",
            gaps.len(),
            q(0.5),
            q(0.95)
        );
    }

    /// The DG fault state at `t`: `inside <kind>` within an interval, `near <kind>` within `margin` seconds
    /// of one's start or end, `None` otherwise.
    pub fn fault_at(&self, t: f64, margin: f64) -> Option<String> {
        for (start, end, kind) in &self.faults {
            if (*start..=*end).contains(&t) {
                let edge = (t - start).min(end - t);
                return Some(if edge < margin { format!("near {kind} edge") } else { format!("inside {kind}") });
            }
            if (t - start).abs() < margin || (t - end).abs() < margin {
                return Some(format!("near {kind} edge"));
            }
        }
        None
    }
}

/// The intervals of the `fault` column's non-empty runs.
fn fault_intervals(rows: &[HashMap<String, String>]) -> Vec<(f64, f64, String)> {
    let mut out: Vec<(f64, f64, String)> = Vec::new();
    let mut open: Option<(f64, String)> = None;
    for r in rows {
        let (t, fault) = (num(r, "time_s"), r.get("fault").cloned().unwrap_or_default());
        match (&open, fault.is_empty()) {
            (Some((start, kind)), true) => {
                out.push((*start, t, kind.clone()));
                open = None;
            }
            (Some((start, kind)), false) if *kind != fault => {
                out.push((*start, t, kind.clone()));
                open = Some((t, fault));
            }
            (None, false) => open = Some((t, fault)),
            _ => {}
        }
    }
    if let (Some((start, kind)), Some(last)) = (open, rows.last()) {
        out.push((start, num(last, "time_s"), kind));
    }
    out
}

/// The ray `origin + s·ray` meeting the least-squares plane through `points` (≥ 3, not collinear).
fn plane_hit(points: &[Vector3<f64>], origin: Vector3<f64>, ray: Vector3<f64>) -> Option<Vector3<f64>> {
    if points.len() < 3 {
        return None;
    }
    let mean = points.iter().sum::<Vector3<f64>>() / points.len() as f64;
    let scatter: Matrix3<f64> = points.iter().map(|p| (p - mean) * (p - mean).transpose()).sum();
    let eig = SymmetricEigen::new(scatter);
    let k = eig.eigenvalues.imin();
    let mut sorted = eig.eigenvalues.as_slice().to_vec();
    sorted.sort_by(f64::total_cmp);
    if sorted[1] < 1e-6 {
        return None;
    }
    let normal = eig.eigenvectors.column(k).into_owned();
    let denom = normal.dot(&ray);
    if denom.abs() < 1e-6 {
        return None;
    }
    let s = normal.dot(&(mean - origin)) / denom;
    (s > 0.0).then(|| origin + ray * s)
}

impl Pixels {
    fn load(dir: &str, id: &str) -> Option<Self> {
        let range = image::open(format!("{dir}/truth/pixels/{id}_range.png")).ok()?.to_luma16();
        let class = image::open(format!("{dir}/truth/pixels/{id}_class.png")).ok()?.to_luma8();
        let (width, height) = range.dimensions();
        Some(Self { width, height, range_mm: range.into_raw(), class: class.into_raw() })
    }

    /// The surface point and class of pixel (`col`, `row`) (columns wrap around), if a surface is stored.
    fn point(&self, camera: &Equirectangular, pose: &MapFromCamera, col: i64, row: i64) -> Option<(Vector3<f64>, u8)> {
        if row < 0 || row >= i64::from(self.height) {
            return None;
        }
        let col = col.rem_euclid(i64::from(self.width));
        let k = usize::try_from(row * i64::from(self.width) + col).ok()?;
        let (range, class) = (self.range_mm[k], self.class[k]);
        if range == 0 {
            return None;
        }
        let d = camera.unproject(Pixel::new(col as f64 + 0.5, row as f64 + 0.5))?;
        Some((pose.translation.p + pose.rotation.matrix() * d.v * (f64::from(range) / 1000.0), class))
    }
}
