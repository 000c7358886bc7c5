//! Step 1, Jende et al. 2017 §3.2: a north-up ortho-image of the ground plane around the panorama's camera, made
//! by back-projection with the DG pose (so it carries the DG error, which step 5 onwards measures).
//!
//! With a terrain model the ground is not a plane: each cell's height is the plane's (the DG camera height
//! minus the rig's camera height, so a DG height error does not scale the image) plus the terrain's rise
//! from the point under the camera to the cell. On a uniform slope that rise does not depend on the DG's
//! horizontal error either; on a level plane an 8 % slope would put ground 10 m ahead 0.8 m off the plane
//! and scale it by a third.

use std::sync::Arc;

use plumbline_geo::{Map, MapFromBody, Point3};
use plumbline_imaging::ortho::{Exposure, GroundGrid, RollingShutter, ortho_project_part};
use plumbline_imaging::seams::{SeamConfig, find_seams, level_seams};
use plumbline_imaging::{GrayImage, ImagePart, Mask};

use super::{MmError, Panorama, PanoramaRig};
use crate::aerial::Terrain;

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
    /// The terrain model and its height under the camera, when the ground follows it.
    pub relief: Option<(Arc<Terrain>, f64)>,
}

impl OrthoPatch {
    /// The mapping-frame point on the ground under continuous ortho pixel (u, v).
    pub fn ground_point(&self, u: f64, v: f64) -> Point3<Map> {
        let [e, n] = self.grid.to_map(u, v);
        Point3::new(e, n, self.height_at(e, n))
    }

    /// The ground's height at (e, n): the plane, raised or lowered by the terrain's rise from under the
    /// camera where a terrain model covers the point.
    pub fn height_at(&self, e: f64, n: f64) -> f64 {
        ground_height(self.plane_height, self.relief.as_ref(), e, n)
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
/// camera centre, on the plane `camera_height` below that centre (Jende et al. 2017 §3.2), vehicle masked. A
/// panorama stitched from a ring of cameras (`rig.sub_cameras`) first has the exposure steps between its
/// cameras levelled (`plumbline_imaging::seams`), and each ground point is seen from its camera's centre.
pub fn ortho_patch(pano: &Panorama, rig: &PanoramaRig, gsd: f64, half_extent: f64) -> Result<OrthoPatch, MmError> {
    let (grid, plane_height) = patch_grid(&pano.id, &pano.pose, rig, gsd, half_extent)?;
    let relief = relief_under(rig, &grid);
    let imaging = |source| MmError::Imaging { image: pano.id.clone(), step: "ortho-projection", source };
    let rolling = pano
        .velocity
        .filter(|_| rig.readout_s > 0.0)
        .map(|velocity| RollingShutter { readout_s: rig.readout_s, velocity });
    let exposure = Exposure {
        camera: &rig.camera,
        mount: &rig.mount,
        pose: &pano.pose,
        sub_cameras: rig.sub_cameras.as_ref(),
        rolling,
    };
    let mask = rig.vehicle_mask.as_ref();
    let levelled = rig.sub_cameras.is_some().then(|| levelled(pano, mask)).flatten();
    let image = levelled.as_ref().unwrap_or(&pano.image);
    let height = |e, n| ground_height(plane_height, relief.as_ref(), e, n);
    let ortho = ortho_project_part(image, &pano.part, mask, &exposure, &grid, height).map_err(imaging)?;
    Ok(OrthoPatch { grid, image: ortho.image, valid: ortho.valid, plane_height, relief })
}

/// The rig's terrain model with its height under the patch's centre (`None` without a model or where it
/// has no data there).
fn relief_under(rig: &PanoramaRig, grid: &GroundGrid) -> Option<(Arc<Terrain>, f64)> {
    let terrain = rig.terrain.as_ref()?;
    let anchor = terrain.height_at(grid.centre[0], grid.centre[1])?;
    Some((Arc::clone(terrain), anchor))
}

/// `plane` raised by the terrain's rise from its anchor to (e, n); the plane where the model has no data.
fn ground_height(plane: f64, relief: Option<&(Arc<Terrain>, f64)>, e: f64, n: f64) -> f64 {
    relief.and_then(|(t, anchor)| t.height_at(e, n).map(|h| plane + h - anchor)).unwrap_or(plane)
}

/// `pano`'s image with the exposure steps between its cameras levelled, compared off the vehicle; `None`
/// when fewer than two seams show (nothing to level).
fn levelled(pano: &Panorama, mask: Option<&Mask>) -> Option<GrayImage> {
    let (step, first) = (pano.part.col_step() as usize, pano.part.first_row() as usize);
    let off_vehicle = |col: usize, row: usize| {
        mask.is_none_or(|m| {
            let (c, r) = (col * step, row + first);
            c < m.width() && r < m.height() && !m.get(c, r)
        })
    };
    let seams = find_seams(&pano.image, off_vehicle, &SeamConfig::default());
    (seams.found.len() >= 2).then(|| {
        let mut image = pano.image.clone();
        level_seams(&mut image, &seams);
        image
    })
}

/// The ground grid of [`ortho_patch`] around the DG camera centre of `pose` (panorama `id`), and its plane
/// height.
fn patch_grid(
    id: &str,
    pose: &MapFromBody,
    rig: &PanoramaRig,
    gsd: f64,
    half_extent: f64,
) -> Result<(GroundGrid, f64), MmError> {
    if !(half_extent.is_finite() && half_extent > 0.0 && gsd.is_finite() && gsd > 0.0 && half_extent / gsd < 10_000.0) {
        return Err(MmError::Config { field: "half_extent/gsd", value: half_extent / gsd, reason: "bad ortho size" });
    }
    if !(rig.camera_height.is_finite() && rig.camera_height > 0.0) {
        return Err(MmError::Config { field: "camera_height", value: rig.camera_height, reason: "must be positive" });
    }
    let centre = rig.mount.camera_pose(pose).translation;
    let side = (2.0 * half_extent / gsd).round() as usize;
    let grid = GroundGrid::new([centre.x(), centre.y()], gsd, side, side, 0.0).map_err(|source| MmError::Imaging {
        image: id.to_owned(),
        step: "ortho-projection",
        source,
    })?;
    Ok((grid, centre.z() - rig.camera_height))
}

/// Boundary points sampled per side of the patch by [`patch_part`].
const BOUNDARY_SAMPLES: usize = 256;

/// Rows kept above the highest row the patch boundary reaches (bilinear footprint and rounding).
const MARGIN_ROWS: f64 = 3.0;

/// Coarsest column step [`patch_part`] chooses.
const MAX_COL_STEP: u32 = 8;

/// The part of the panorama taken at `pose` that [`ortho_patch`] samples, so a worker decodes no more:
/// the rows from just above the highest row the patch's boundary projects to (the ground plane's highest
/// point in the image lies on its boundary) down to the nadir, and the coarsest power-of-two column step
/// (at most 8) at which one column still spans no more than `gsd` on the ground at the
/// patch's farthest point. The whole image when any boundary point does not project.
pub fn patch_part(pose: &MapFromBody, rig: &PanoramaRig, gsd: f64, half_extent: f64) -> ImagePart {
    let (w, h) = (rig.camera.width, rig.camera.height);
    let whole = ImagePart::whole(w, h);
    let Ok((grid, plane)) = patch_grid("", pose, rig, gsd, half_extent) else {
        return whole;
    };
    let relief = relief_under(rig, &grid);
    let side = grid.width as f64;
    let (mut top, mut reach) = (f64::INFINITY, 0.0_f64);
    for i in 0..=BOUNDARY_SAMPLES {
        let t = side * i as f64 / BOUNDARY_SAMPLES as f64;
        for (u, v) in [(t, 0.0), (t, side), (0.0, t), (side, t)] {
            let [e, n] = grid.to_map(u, v);
            let height = ground_height(plane, relief.as_ref(), e, n);
            let Some(px) = rig.mount.project(&rig.camera, pose, &Point3::<Map>::new(e, n, height)) else {
                return whole;
            };
            top = top.min(px.v);
            reach = reach.max((e - grid.centre[0]).hypot(n - grid.centre[1]));
        }
    }
    let first_row = (top - MARGIN_ROWS).floor().clamp(0.0, f64::from(h - 1)) as u32;
    let needed_columns = std::f64::consts::TAU * reach / gsd;
    let mut step = 1;
    while step < MAX_COL_STEP && w.is_multiple_of(2 * step) && f64::from(w / (2 * step)) >= needed_columns {
        step *= 2;
    }
    ImagePart::new(w, h, first_row, step).unwrap_or(whole)
}

#[cfg(test)]
mod tests {
    use super::*;
    use plumbline_geo::camera::Equirectangular;

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

    /// Texture cells within 5 m of the camera (away from marking edges) whose ortho value differs from the
    /// ground's, and the cells checked.
    fn misplaced(patch: &OrthoPatch, ground: &Ground, at: [f64; 2]) -> (usize, usize) {
        let (mut checked, mut bad) = (0, 0);
        for r in (0..patch.grid.height).step_by(5) {
            for c in (0..patch.grid.width).step_by(5) {
                let p = patch.ground_point(c as f64 + 0.5, r as f64 + 0.5);
                let d = (p.x() - at[0]).hypot(p.y() - at[1]);
                if !patch.valid.get(c, r) || d > 5.0 || !ground.is_flat_at(p.x(), p.y(), 0.1) {
                    continue;
                }
                checked += 1;
                bad += usize::from((patch.image.get(c, r) - ground.value(p.x(), p.y())).abs() > 6.0);
            }
        }
        (bad, checked)
    }

    /// On an 8 % slope the ortho-image follows a terrain model (1 m cells) and shows the texture where it
    /// lies; projected on the level plane, ground 5 m uphill is 0.4 m off the plane and lands 0.7 m off.
    #[test]
    fn on_a_slope_the_ortho_image_follows_the_terrain_model() {
        let mut ground = Ground::markings(5, [0.0, 0.0], 12.0);
        ground.slope = [0.08 * 0.6, 0.08 * 0.8];
        let mut rig = rig(true);
        let at = [1.3, -0.7];
        let pano = scene_panorama("p", &ground, &rig, at, 0.4, [0.0; 3]);
        let level = ortho_patch(&pano, &rig, 0.03, 6.0).unwrap();
        let (w, h) = (40usize, 40usize);
        let heights = (0..w * h)
            .map(|i| ground.height_at(-20.0 + (i % w) as f64 + 0.5, 20.0 - (i / w) as f64 - 0.5) as f32)
            .collect();
        rig.terrain =
            Some(Arc::new(Terrain { heights, width: w, height: h, geotransform: [-20.0, 1.0, 0.0, 20.0, 0.0, -1.0] }));
        let relief = ortho_patch(&pano, &rig, 0.03, 6.0).unwrap();
        let p = relief.ground_point(100.5, 300.5);
        assert!((p.z() - ground.height_at(p.x(), p.y())).abs() < 0.05, "ground point {p:?}");
        let ((bad, checked), (level_bad, level_checked)) =
            (misplaced(&relief, &ground, at), misplaced(&level, &ground, at));
        assert!(checked > 1000 && bad * 50 < checked, "with the terrain model {bad} of {checked} cells differ");
        // Smooth texture hides much of the level plane's displacement; a tenth of the cells still show it.
        println!(
            "cells differing: {bad} of {checked} with the terrain model, {level_bad} of {level_checked} on the plane"
        );
        assert!(
            level_bad * 10 > level_checked && level_bad > 5 * bad.max(1),
            "the level plane: {level_bad} of {level_checked}"
        );
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

    /// The part of the panorama whose pixels a worker decodes: the patch from it equals the patch from
    /// the whole panorama, cell for cell, while it holds well under half the rows.
    #[test]
    fn the_patch_part_of_a_panorama_gives_the_same_patch_as_the_whole() {
        let ground = Ground::markings(4, [0.0, 0.0], 16.0);
        let rig = rig(true);
        // Level, and tilted as on a steep, cambered street (the pose alone decides the part).
        let cases = [
            ([1.3, -0.7], 0.4, 6.0, [0.0, 0.0]),
            ([-2.0, 3.1], 2.9, 14.0, [0.0, 0.0]),
            ([0.5, 0.5], 1.1, 14.0, [3.0_f64, -5.0_f64]),
        ];
        for (at, heading, half, [roll, pitch]) in cases {
            let mut whole = scene_panorama("p", &ground, &rig, at, heading, [0.05, -0.03, 0.02]);
            let attitude = plumbline_geo::Attitude::new(roll.to_radians(), pitch.to_radians(), heading);
            whole.pose = MapFromBody::new(attitude.to_rotation(), whole.pose.translation);
            let part = patch_part(&whole.pose, &rig, 0.03, half);
            assert_eq!(part.col_step(), 1, "1024 columns resolve 3 cm nowhere near the patch edge");
            assert!(part.height() * 2 < whole.image.height(), "{} of {} rows", part.height(), whole.image.height());
            let cut = Panorama { image: part.extract(whole.image.data()).unwrap(), part, ..whole.clone() };
            let (a, b) = (ortho_patch(&whole, &rig, 0.03, half).unwrap(), ortho_patch(&cut, &rig, 0.03, half).unwrap());
            assert!(a.valid.count() > a.valid.data().len() / 2, "{} valid cells", a.valid.count());
            assert_eq!(a.valid, b.valid);
            assert_eq!(a.image, b.image);
        }
    }

    /// A 16384-px panorama needs only every second column for a 3 cm patch of ±14 m (a column spans
    /// 2π · 19.8 m / 8192 = 1.5 cm at its corners), and a coarser grid or smaller patch allows more.
    #[test]
    fn the_column_step_follows_the_ground_resolution_the_patch_needs() {
        let mut rig = rig(false);
        let pose = scene_panorama("p", &Ground::markings(1, [0.0, 0.0], 5.0), &rig, [0.0, 0.0], 0.0, [0.0; 3]).pose;
        rig.camera = Equirectangular { width: 16384, height: 8192 };
        assert_eq!(patch_part(&pose, &rig, 0.03, 14.0).col_step(), 2);
        assert_eq!(patch_part(&pose, &rig, 0.12, 14.0).col_step(), 8);
        rig.camera = Equirectangular { width: 4096, height: 2048 };
        assert_eq!(patch_part(&pose, &rig, 0.03, 14.0).col_step(), 1);
        let part = patch_part(&pose, &rig, 0.03, 14.0);
        // The patch corner at 19.8 m lies 8.2° below the horizon (camera 2.85 m up, boresight < 1°).
        let latitude = 90.0 - f64::from(part.first_row()) / 2048.0 * 180.0;
        assert!((latitude + 8.2).abs() < 1.5, "first row at {latitude:.2}°");
    }
}
