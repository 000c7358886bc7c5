//! Meridian convergence of a projected CRS at a point, computed numerically through GDAL.

use super::{CrsError, CrsTransform, spatial_ref};

/// Half the latitude step of the central difference, in degrees (about 1.1 m on the ground):
/// small enough that the meridian is straight on the grid, large enough that grid rounding
/// (~1e-9 m) stays far below 1e-6 rad.
const HALF_STEP_DEG: f64 = 1e-5;

/// The meridian convergence γ in radians at (`lon_deg`, `lat_deg`) — geographic coordinates on
/// the projected CRS's own datum — in projected CRS `epsg_projected`.
///
/// γ is the angle between true north and grid north, positive when grid north lies clockwise of
/// true north, so that **grid heading = true heading − γ**. It is positive east of a transverse
/// Mercator central meridian in the northern hemisphere (where true north leans to grid west);
/// for UTM it matches γ ≈ atan(tan(λ − λ0) · sin φ).
///
/// Computed by projecting two points a small step south and north along the meridian and taking
/// the direction of their grid displacement, so it works for any projection GDAL knows.
pub fn meridian_convergence(epsg_projected: u32, lon_deg: f64, lat_deg: f64) -> Result<f64, CrsError> {
    MeridianConvergence::new(epsg_projected)?.at(lon_deg, lat_deg)
}

/// [`meridian_convergence`] for many points of one projected CRS: the GDAL transformation is built once.
/// Not `Send`, like [`CrsTransform`].
#[derive(Debug)]
pub struct MeridianConvergence {
    to_grid: CrsTransform,
}

impl MeridianConvergence {
    /// Prepare for projected CRS `epsg_projected` (an error when it is unknown or not projected).
    pub fn new(epsg_projected: u32) -> Result<Self, CrsError> {
        let projected = spatial_ref(epsg_projected)?;
        if !projected.is_projected() {
            return Err(CrsError::NotProjected { code: epsg_projected });
        }
        let mut geographic =
            projected.geog_cs().map_err(|source| CrsError::UnknownEpsg { code: epsg_projected, source })?;
        geographic.set_axis_mapping_strategy(gdal::spatial_ref::AxisMappingStrategy::TraditionalGisOrder);
        let geographic_code = geographic.auth_code().ok().and_then(|code| u32::try_from(code).ok()).unwrap_or(0);
        let to_grid = CrsTransform::between(&geographic, &projected, geographic_code, epsg_projected)?;
        Ok(Self { to_grid })
    }

    /// γ in radians at (`lon_deg`, `lat_deg`), as [`meridian_convergence`] defines it.
    pub fn at(&self, lon_deg: f64, lat_deg: f64) -> Result<f64, CrsError> {
        let mut xs = [lon_deg, lon_deg];
        let mut ys = [lat_deg - HALF_STEP_DEG, lat_deg + HALF_STEP_DEG];
        self.to_grid.transform(&mut xs, &mut ys, &mut [])?;
        let (d_east, d_north) = (xs[1] - xs[0], ys[1] - ys[0]);
        // True north points along (d_east, d_north) on the grid, at grid azimuth atan2(dE, dN) = −γ.
        Ok(-d_east.atan2(d_north))
    }
}
