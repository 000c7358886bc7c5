//! Moving trajectory records between CRSs through GDAL: positions by PROJ, headings by meridian convergence.
//!
//! Grid heading = true heading − γ, where γ is the meridian convergence of the projected CRS at the point.
//! A projected → projected change goes through geographic coordinates: ψ_b = ψ_a + γ_a − γ_b.

use crate::crs::{CrsError, CrsTransform, MeridianConvergence};
use plumbline_geo::formats::{Horizontal, MapPoint, RawTrajectory};
use plumbline_geo::{Trajectory, TrajectoryRecord, ValidationLimits};

/// A projected CRS and the geographic CRS its inputs/outputs use, with transforms both ways.
pub struct Projection {
    projected: u32,
    convergence: MeridianConvergence,
    to_map: CrsTransform,
    to_geographic: CrsTransform,
}

impl std::fmt::Debug for Projection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Projection(EPSG:{} ↔ EPSG:{})", self.to_map.from_epsg(), self.projected)
    }
}

impl Projection {
    /// Transforms between geographic `geographic` (lon/lat degrees) and projected `projected` (metres).
    pub fn new(geographic: u32, projected: u32) -> Result<Self, CrsError> {
        Ok(Self {
            projected,
            convergence: MeridianConvergence::new(projected)?,
            to_map: CrsTransform::new(geographic, projected)?,
            to_geographic: CrsTransform::new(projected, geographic)?,
        })
    }

    /// Geographic → projected, with the convergence at the point.
    pub fn project(&self, lon: f64, lat: f64, h: f64) -> Result<MapPoint, CrsError> {
        let (e, n, h) = self.to_map.transform_point(lon, lat, h)?;
        let convergence = self.convergence.at(lon, lat)?;
        Ok(MapPoint { e, n, h, convergence_rad: convergence })
    }

    /// Projected → geographic, with the convergence at the point.
    pub fn unproject(&self, e: f64, n: f64, h: f64) -> Result<(f64, f64, f64, f64), CrsError> {
        let (lon, lat, h) = self.to_geographic.transform_point(e, n, h)?;
        let convergence = self.convergence.at(lon, lat)?;
        Ok((lon, lat, h, convergence))
    }
}

/// True when the EPSG code names a projected CRS (an unknown code is an error naming it).
pub fn is_projected(epsg: u32) -> Result<bool, CrsError> {
    crate::crs::is_projected(epsg)
}

/// The WGS84 UTM zone (EPSG 326xx north, 327xx south) of the first record of a geographic trajectory.
pub fn utm_zone_of(raw: &RawTrajectory) -> Result<u32, String> {
    let first = raw.records.first().ok_or("the trajectory is empty")?;
    let (lon, lat) = (first.x, first.y);
    if !(lon.is_finite() && lat.is_finite() && (-180.0..=180.0).contains(&lon) && (-84.0..=84.0).contains(&lat)) {
        return Err(format!("record 0: ({lon}, {lat}) is not a longitude/latitude inside the UTM range"));
    }
    let zone = (((lon + 180.0) / 6.0).floor() as u32).min(59) + 1;
    Ok(if lat >= 0.0 { 32600 + zone } else { 32700 + zone })
}

/// Bring raw records with coordinates in `source` (an EPSG code; `None` = already in `target`) into the
/// projected CRS `target` (`None`: keep projected records as they are), validated as a trajectory.
pub fn into_projected(raw: RawTrajectory, source: Option<u32>, target: Option<u32>) -> crate::Result<Trajectory> {
    let records: Vec<TrajectoryRecord> = match (raw.horizontal, source, target) {
        (Horizontal::Projected, None, _) | (Horizontal::Projected, _, None) => raw.into_map(no_projection)?,
        (Horizontal::Projected, Some(s), Some(t)) if s == t => raw.into_map(no_projection)?,
        (Horizontal::Projected, Some(s), Some(t)) => {
            let from = Projection::new(4326, s)?;
            let geographic = RawTrajectory::from_map(&raw.into_map(no_projection)?, |e, n, h| from.unproject(e, n, h))?;
            let to = Projection::new(4326, t)?;
            geographic.into_map(|lon, lat, h| to.project(lon, lat, h))?
        }
        (Horizontal::Geographic, s, Some(t)) => {
            let to = Projection::new(s.unwrap_or(4326), t)?;
            raw.into_map(|lon, lat, h| to.project(lon, lat, h))?
        }
        (Horizontal::Geographic, _, None) => return Err(crate::invalid("geographic coordinates need a projected CRS")),
    };
    Ok(Trajectory::new(records, &ValidationLimits::default())?)
}

/// Express a trajectory in projected CRS `source` in `target`: projected easting/northing, or geographic.
pub fn express(trajectory: &Trajectory, source: u32, target: u32) -> crate::Result<RawTrajectory> {
    if !is_projected(target)? {
        let p = Projection::new(target, source)?;
        return Ok(RawTrajectory::from_map(trajectory.records(), |e, n, h| p.unproject(e, n, h))?);
    }
    if source == target {
        return Ok(RawTrajectory::from_map_projected(trajectory.records()));
    }
    let from = Projection::new(4326, source)?;
    let geographic = RawTrajectory::from_map(trajectory.records(), |e, n, h| from.unproject(e, n, h))?;
    let moved = into_projected(geographic, Some(4326), Some(target))?;
    Ok(RawTrajectory::from_map_projected(moved.records()))
}

fn no_projection(_: f64, _: f64, _: f64) -> Result<MapPoint, std::convert::Infallible> {
    unreachable!("projected records are moved without calling the projection")
}
