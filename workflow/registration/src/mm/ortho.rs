//! Step 1, paper 000 §3.2: a north-up ortho-image of the ground plane around the panorama's camera, made
//! by back-projection with the DG pose (so it carries the DG error, which step 5 onwards measures).

use plumbline_geo::{Map, Point3};
use plumbline_imaging::ortho::{Exposure, GroundGrid, ortho_project};
use plumbline_imaging::{GrayImage, Mask};

use super::{MmError, Panorama, PanoramaRig};

/// An ortho-image of one panorama on its ground plane.
#[derive(Clone, Debug)]
pub struct OrthoPatch {
    /// The raster on the ground (north-up), centred below the DG camera centre.
    pub grid: GroundGrid,
    /// Ortho-projected gray values (0 where invalid).
    pub image: GrayImage,
    /// Cells that received a sample (not on the vehicle, not off the panorama).
    pub valid: Mask,
    /// Height of the ground plane, metres: the DG camera height minus the rig's camera height.
    pub plane_height: f64,
}

impl OrthoPatch {
    /// The mapping-frame point on the ground plane under continuous ortho pixel (u, v).
    pub fn ground_point(&self, u: f64, v: f64) -> Point3<Map> {
        let [e, n] = self.grid.to_map(u, v);
        Point3::new(e, n, self.plane_height)
    }

    /// True when every cell within `half` pixels (Chebyshev) of pixel (col, row) exists and is valid.
    pub fn valid_around(&self, col: isize, row: isize, half: usize) -> bool {
        let h = half as isize;
        let (w, ht) = (self.valid.width() as isize, self.valid.height() as isize);
        if col - h < 0 || row - h < 0 || col + h >= w || row + h >= ht {
            return false;
        }
        (row - h..=row + h).all(|r| (col - h..=col + h).all(|c| self.valid.get(c as usize, r as usize)))
    }
}

/// Ortho-project `pano` at `gsd` onto a north-up square of half-side `half_extent` metres around its DG
/// camera centre, on the plane `camera_height` below that centre (paper 000 §3.2), vehicle masked.
pub fn ortho_patch(pano: &Panorama, rig: &PanoramaRig, gsd: f64, half_extent: f64) -> Result<OrthoPatch, MmError> {
    if !(half_extent.is_finite() && half_extent > 0.0 && gsd.is_finite() && gsd > 0.0 && half_extent / gsd < 10_000.0) {
        return Err(MmError::Config { field: "half_extent/gsd", value: half_extent / gsd, reason: "bad ortho size" });
    }
    if !(rig.camera_height.is_finite() && rig.camera_height > 0.0) {
        return Err(MmError::Config { field: "camera_height", value: rig.camera_height, reason: "must be positive" });
    }
    let imaging = |source| MmError::Imaging { image: pano.id.clone(), step: "ortho-projection", source };
    let centre = rig.mount.camera_pose(&pano.pose).translation;
    let plane_height = centre.z() - rig.camera_height;
    let side = (2.0 * half_extent / gsd).round() as usize;
    let grid = GroundGrid::new([centre.x(), centre.y()], gsd, side, side, 0.0).map_err(imaging)?;
    let exposure = Exposure { camera: &rig.camera, mount: &rig.mount, pose: &pano.pose };
    let ortho = ortho_project(&pano.image, rig.vehicle_mask.as_ref(), &exposure, &grid, |_, _| plane_height)
        .map_err(imaging)?;
    Ok(OrthoPatch { grid, image: ortho.image, valid: ortho.valid, plane_height })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mm::testing::{Ground, rig, scene_panorama};

    #[test]
    fn ortho_image_shows_the_ground_texture_at_its_map_position_and_masks_the_vehicle() {
        let ground = Ground::markings(3, [0.0, 0.0], 12.0);
        let rig = rig(true);
        let pano = scene_panorama("p", &ground, &rig, [1.3, -0.7], 0.4, [0.0; 3]);
        let patch = ortho_patch(&pano, &rig, 0.03, 6.0).unwrap();
        assert_eq!((patch.grid.width, patch.grid.height), (400, 400));
        assert!((patch.plane_height - ground.height).abs() < 1e-9, "plane at {}", patch.plane_height);
        // Within 4 m of the camera the panorama resolves the texture; the ortho value at each valid cell
        // must equal the texture there (a wrong plane height or centre scales or shifts it by many pixels).
        let (mut checked, mut bad) = (0, 0);
        for r in (0..400).step_by(7) {
            for c in (0..400).step_by(7) {
                let (u, v) = (c as f64 + 0.5, r as f64 + 0.5);
                let p = patch.ground_point(u, v);
                let d = (p.x() - 1.3).hypot(p.y() + 0.7);
                if !patch.valid.get(c, r) || d > 4.0 || !ground.is_flat_at(p.x(), p.y(), 0.1) {
                    continue;
                }
                checked += 1;
                bad += usize::from((patch.image.get(c, r) - ground.value(p.x(), p.y())).abs() > 6.0);
            }
        }
        assert!(checked > 400 && bad * 50 < checked, "{bad} of {checked} cells differ");
        // The van (4.6 m × 1.9 m around the body origin) hides the cells straight below the camera.
        let [u, v] = patch.grid.to_pixel(1.3, -0.7);
        assert!(!patch.valid.get(u as usize, v as usize));
    }

    #[test]
    fn bad_sizes_are_errors_naming_the_field() {
        let ground = Ground::markings(1, [0.0, 0.0], 5.0);
        let mut rig = rig(false);
        let pano = scene_panorama("p", &ground, &rig, [0.0, 0.0], 0.0, [0.0; 3]);
        assert!(matches!(ortho_patch(&pano, &rig, 0.0, 5.0), Err(MmError::Config { .. })));
        rig.camera_height = -1.0;
        let err = ortho_patch(&pano, &rig, 0.03, 5.0).unwrap_err();
        assert!(err.to_string().contains("camera_height"), "{err}");
    }
}
