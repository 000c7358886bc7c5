//! The ground truth under every pixel of a panorama: the distance along the pixel-centre ray to the first
//! surface (16-bit, millimetres) and what that surface is. With the TRUE camera pose at exposure (the body pose
//! of `truth/images.csv` and the manifest's mount) the mapping-frame point of pixel (col, row) is
//! `C + range · R·d(col + 0.5, row + 0.5)` ([`surface_point`]), exact to the rounding of the range (0.5 mm).

use image::{GrayImage, ImageBuffer, Luma};
use nalgebra::Vector3;
use plumbline_geo::camera::{CameraModel, Pixel};
use plumbline_geo::dg::CameraMount;
use plumbline_geo::{Map, MapFromBody, MapFromCamera, Point3};
use rayon::prelude::*;

use super::frame::VehicleBody;
use crate::world::{Epoch, Surface, World};

/// Farthest range a 16-bit millimetre value holds, metres; farther surfaces are stored as [`SurfaceClass::None`].
pub const MAX_RANGE_M: f64 = 65.534;

/// What lies under a pixel, as stored in the class image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum SurfaceClass {
    /// Sky, or a surface beyond [`MAX_RANGE_M`]; range 0.
    None = 0,
    /// The ground (road, sidewalk, yards).
    Ground = 1,
    /// A building's wall.
    Facade = 2,
    /// A building's roof.
    Roof = 3,
    /// A pole or tree trunk.
    Pole = 4,
    /// A tree crown.
    Crown = 5,
    /// A parked car.
    Car = 6,
    /// The vehicle's own body (masked in the panorama); range 0.
    Vehicle = 7,
    /// A pedestrian.
    Pedestrian = 8,
}

impl SurfaceClass {
    /// The class of a ray-cast surface.
    pub fn of(surface: Surface) -> Self {
        match surface {
            Surface::Ground => SurfaceClass::Ground,
            Surface::Facade(_) => SurfaceClass::Facade,
            Surface::Roof(_) => SurfaceClass::Roof,
            Surface::Pole(_) => SurfaceClass::Pole,
            Surface::Crown(_) => SurfaceClass::Crown,
            Surface::Car(_) => SurfaceClass::Car,
            Surface::Pedestrian(_) => SurfaceClass::Pedestrian,
        }
    }

    /// The class of a stored code (`None` for codes no class has).
    pub fn from_code(code: u8) -> Option<Self> {
        [
            Self::None,
            Self::Ground,
            Self::Facade,
            Self::Roof,
            Self::Pole,
            Self::Crown,
            Self::Car,
            Self::Vehicle,
            Self::Pedestrian,
        ]
        .get(usize::from(code))
        .copied()
    }
}

/// Range and class images of one camera exposure.
#[derive(Clone, Debug)]
pub struct SurfaceImage {
    /// Distance from the camera centre along the pixel-centre ray, millimetres; 0 = no surface stored.
    pub range_mm: ImageBuffer<Luma<u16>, Vec<u16>>,
    /// [`SurfaceClass`] codes.
    pub class: GrayImage,
}

/// The first surface under every pixel centre of a camera mounted at `mount` on a vehicle at `body` (the
/// vehicle's own body, `vehicle`, hides what lies behind it), as the scene was at `epoch`.
pub fn render_surfaces<C: CameraModel + Sync>(
    world: &World,
    epoch: Epoch,
    cam: &C,
    mount: &CameraMount,
    body: &MapFromBody,
    vehicle: &VehicleBody,
) -> SurfaceImage {
    let pose = mount.camera_pose(body);
    let (w, h) = (cam.width(), cam.height());
    let to_body = body.inverse();
    let o_body = to_body.transform_point(&pose.translation).p;
    let mut range = vec![0u16; (w * h) as usize];
    let mut class = vec![0u8; (w * h) as usize];
    range.par_chunks_mut(w as usize).zip(class.par_chunks_mut(w as usize)).enumerate().for_each(|(row, (r, c))| {
        for col in 0..w {
            let Some(d) = cam.unproject(Pixel::new(f64::from(col) + 0.5, row as f64 + 0.5)) else { continue };
            let d = pose.rotation.apply(&d).v;
            if vehicle.hit(&o_body, &(to_body.rotation.quaternion() * d)).is_some() {
                c[col as usize] = SurfaceClass::Vehicle as u8;
                continue;
            }
            let Some(hit) = world.trace(&pose.translation.p, &d, MAX_RANGE_M, epoch) else { continue };
            r[col as usize] = (hit.t * 1000.0).round() as u16;
            c[col as usize] = SurfaceClass::of(hit.surface) as u8;
        }
    });
    SurfaceImage {
        range_mm: ImageBuffer::from_raw(w, h, range).unwrap_or_default(),
        class: GrayImage::from_raw(w, h, class).unwrap_or_default(),
    }
}

/// The mapping-frame point of pixel (`col`, `row`) at `range_m` along its centre ray from a camera at `pose`;
/// `None` when the pixel forms no ray.
pub fn surface_point<C: CameraModel>(
    cam: &C,
    pose: &MapFromCamera,
    col: u32,
    row: u32,
    range_m: f64,
) -> Option<Point3<Map>> {
    let d = pose.rotation.apply(&cam.unproject(Pixel::new(f64::from(col) + 0.5, f64::from(row) + 0.5))?).v;
    let p: Vector3<f64> = pose.translation.p + d * range_m;
    Some(Point3::from_vector(p))
}
