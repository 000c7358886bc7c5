//! The plan of a campaign run: which tile processes which panoramas, pairs and depth images. Made once by
//! the scheduler (or `plumbline run`) from the image indexes and the DG trajectory, stored as `plan.json`
//! next to the results, and read by every worker, so tasks only carry a tile id.
//!
//! Panoramas are placed by their DG camera-station position (the vehicle position interpolated at the
//! exposure time) and tiled with [`plumbline_geo::tiling::plan`]. A depth image goes to the tile of the
//! panorama nearest to it in time, so that every depth image has a tile even where a cell holds no
//! panorama. Images whose time lies outside the trajectory are skipped and listed, never fatal.

use plumbline_geo::tiling::{self, ImageId, ImageSite, TileId, TilePlan, TilingError, TilingParams};
use plumbline_geo::trajectory::{PositionInterpolation, Trajectory};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::tables::IndexRow;

/// A plan of any supported version, tagged by `"version"`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "version")]
pub enum PlanDoc {
    /// Version 1.
    #[serde(rename = "1")]
    V1(CampaignPlan),
}

/// A planned image: its index row and where the DG trajectory puts it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PlannedImage {
    /// The planner's id (position in [`CampaignPlan::panoramas`] or [`CampaignPlan::depth`]).
    pub id: ImageId,
    /// Id, time and file from the index.
    pub image_id: String,
    /// Exposure time, seconds.
    pub time: f64,
    /// File relative to the images prefix.
    pub file: String,
    /// DG easting at the exposure, metres.
    pub east: f64,
    /// DG northing at the exposure, metres.
    pub north: f64,
    /// For depth images, the depth camera (index into the manifest's `[[depth]]`); 0 for panoramas.
    pub camera: usize,
}

/// An index row left out of the plan, and why.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Unplanned {
    /// Which index (`panoramas`, `depth[0]`, …).
    pub source: String,
    /// The image id.
    pub image_id: String,
    /// Why it was left out.
    pub reason: String,
}

/// Depth images of one tile.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TileDepth {
    /// The tile.
    pub tile: TileId,
    /// Indices into [`CampaignPlan::depth`], in time order.
    pub depth: Vec<usize>,
}

/// The plan: tiles of panoramas and pairs, the depth images of each tile, and what was left out.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CampaignPlan {
    /// The tiling used.
    pub params: TilingParams,
    /// Panoramas in time order; `ImageId(i)` is `panoramas[i]`.
    pub panoramas: Vec<PlannedImage>,
    /// Depth images (all depth cameras) in time order.
    pub depth: Vec<PlannedImage>,
    /// The tiles (row-major), each with its owned and context panoramas and its pairs.
    pub tiles: TilePlan,
    /// Depth images per tile, for tiles that have any.
    pub tile_depth: Vec<TileDepth>,
    /// Rows left out.
    pub unplanned: Vec<Unplanned>,
}

/// Why no plan could be made at all.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// The tiling parameters or positions were rejected.
    #[error("tiling: {0}")]
    Tiling(#[from] TilingError),
}

/// Place index rows on the trajectory: planned images in time order, and the rows that could not be placed.
fn place(source: &str, rows: &[IndexRow], trajectory: &Trajectory) -> (Vec<PlannedImage>, Vec<Unplanned>) {
    let mut rows: Vec<&IndexRow> = rows.iter().collect();
    rows.sort_by(|a, b| a.time.total_cmp(&b.time).then_with(|| a.image_id.cmp(&b.image_id)));
    let (mut placed, mut left) = (Vec::new(), Vec::new());
    for row in rows {
        match trajectory.interpolate(row.time, PositionInterpolation::Linear) {
            Ok(r) => placed.push(PlannedImage {
                id: ImageId(placed.len() as u64),
                image_id: row.image_id.clone(),
                time: row.time,
                file: row.file.clone(),
                east: r.position.x(),
                north: r.position.y(),
                camera: 0,
            }),
            Err(e) => left.push(Unplanned {
                source: source.to_owned(),
                image_id: row.image_id.clone(),
                reason: format!("time {}: {e}", row.time),
            }),
        }
    }
    (placed, left)
}

/// Plan a campaign from its panorama index, its depth indexes (one per depth camera, in manifest order)
/// and the DG trajectory.
pub fn plan_campaign(
    panoramas: &[IndexRow],
    depth: &[Vec<IndexRow>],
    trajectory: &Trajectory,
    params: &TilingParams,
) -> Result<CampaignPlan, PlanError> {
    let (panoramas, mut unplanned) = place("panoramas", panoramas, trajectory);
    let sites: Vec<ImageSite> =
        panoramas.iter().map(|p| ImageSite { id: p.id, time: p.time, east: p.east, north: p.north }).collect();
    let tiles = tiling::plan(&sites, params)?;
    let mut depth_images = Vec::new();
    for (camera, rows) in depth.iter().enumerate() {
        let (placed, left) = place(&format!("depth[{camera}]"), rows, trajectory);
        unplanned.extend(left);
        depth_images.extend(placed.into_iter().map(|p| PlannedImage { camera, ..p }));
    }
    depth_images.sort_by(|a, b| a.time.total_cmp(&b.time).then_with(|| a.camera.cmp(&b.camera)));
    for (i, d) in depth_images.iter_mut().enumerate() {
        d.id = ImageId(i as u64);
    }
    let depth = depth_images;
    let tile_depth = depth_by_tile(&panoramas, &depth, &tiles);
    Ok(CampaignPlan { params: *params, panoramas, depth, tiles, tile_depth, unplanned })
}

/// Each depth image goes to the tile owning the panorama nearest in time.
fn depth_by_tile(panoramas: &[PlannedImage], depth: &[PlannedImage], tiles: &TilePlan) -> Vec<TileDepth> {
    let mut by_tile: std::collections::BTreeMap<TileId, Vec<usize>> = Default::default();
    for (k, d) in depth.iter().enumerate() {
        let after = panoramas.partition_point(|p| p.time < d.time);
        let nearest = [after.checked_sub(1), (after < panoramas.len()).then_some(after)]
            .into_iter()
            .flatten()
            .min_by(|&a, &b| (panoramas[a].time - d.time).abs().total_cmp(&(panoramas[b].time - d.time).abs()));
        if let Some(tile) = nearest.and_then(|i| tiles.tile_of(panoramas[i].id)) {
            by_tile.entry(*tile).or_default().push(k);
        }
    }
    by_tile.into_iter().map(|(tile, depth)| TileDepth { tile, depth }).collect()
}

impl CampaignPlan {
    /// The depth images of a tile (indices into [`CampaignPlan::depth`]).
    pub fn depth_of(&self, tile: &TileId) -> &[usize] {
        self.tile_depth.iter().find(|t| &t.tile == tile).map_or(&[], |t| &t.depth)
    }

    /// The share of the drive's time a tile owns: the times nearer to one of its panoramas than to any other
    /// panorama (the rule depth images are assigned by), as sorted, merged spans; the drive's first and last
    /// spans reach to ±∞. Point-cloud slices go to the tile whose spans hold their middle time.
    pub fn time_spans_of(&self, tile: &TileId) -> Vec<std::ops::Range<f64>> {
        let p = &self.panoramas;
        let mut out: Vec<std::ops::Range<f64>> = Vec::new();
        for (i, pano) in p.iter().enumerate() {
            if self.tiles.tile_of(pano.id) != Some(tile) {
                continue;
            }
            let start = i.checked_sub(1).map_or(f64::NEG_INFINITY, |j| 0.5 * (p[j].time + pano.time));
            let end = p.get(i + 1).map_or(f64::INFINITY, |next| 0.5 * (pano.time + next.time));
            match out.last_mut() {
                Some(last) if last.end >= start => last.end = end,
                _ => out.push(start..end),
            }
        }
        out
    }

    /// `plan.json`: the versioned document.
    pub fn to_json(&self) -> Vec<u8> {
        serde_json::to_vec_pretty(&PlanDoc::V1(self.clone())).unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use plumbline_geo::attitude::Attitude;
    use plumbline_geo::frames::Point3;
    use plumbline_geo::trajectory::{TrajectoryRecord, ValidationLimits};

    use super::*;

    /// A straight drive east at 10 m/s from E 0, t = 0…100 s, sampled at 10 Hz.
    fn drive() -> Trajectory {
        let records = (0..=1000)
            .map(|i| {
                let t = f64::from(i) * 0.1;
                TrajectoryRecord {
                    time: t,
                    position: Point3::new(10.0 * t + 0.5, 5.0, 10.0),
                    attitude: Attitude::from_degrees(0.0, 0.0, 90.0),
                    std: None,
                }
            })
            .collect();
        Trajectory::new(records, &ValidationLimits::default()).unwrap()
    }

    fn row(id: &str, time: f64) -> IndexRow {
        IndexRow { image_id: id.into(), time, file: format!("{id}.jpg") }
    }

    #[test]
    fn panoramas_are_tiled_by_their_dg_position_and_depth_follows_the_nearest_panorama() {
        // Panoramas every second (10 m), one outside the trajectory; tiles of 100 m.
        let mut panos: Vec<IndexRow> = (0..=60).map(|i| row(&format!("p{i:02}"), f64::from(i))).collect();
        panos.push(row("late", 250.0));
        panos.swap(3, 40); // index order is not time order
        let depth = vec![vec![row("d0", 0.2), row("d2", 99.0)], vec![row("d1", 19.6), row("gone", -5.0)]];
        let plan = plan_campaign(&panos, &depth, &drive(), &TilingParams::new(100.0, 10.0)).unwrap();
        assert_eq!(plan.panoramas.len(), 61);
        assert!(plan.panoramas.windows(2).all(|w| w[0].time < w[1].time));
        let unplanned: Vec<(&str, &str)> =
            plan.unplanned.iter().map(|u| (u.source.as_str(), u.image_id.as_str())).collect();
        assert_eq!(unplanned, [("panoramas", "late"), ("depth[1]", "gone")]);
        let cameras: Vec<(&str, usize)> = plan.depth.iter().map(|d| (d.image_id.as_str(), d.camera)).collect();
        assert_eq!(cameras, [("d0", 0), ("d1", 1), ("d2", 0)]);
        // E = 10 t + 0.5: p00–p09 in column 0, p10–p19 in column 1, …
        let first = &plan.tiles.tiles()[0];
        assert_eq!(first.id, TileId { col: 0, row: 0 });
        assert_eq!(first.owned.len(), 10);
        assert_eq!(first.pairs.last(), Some(&(ImageId(9), ImageId(10))), "the pair across the border");
        // d0 → p00 (tile c0), d1 at 19.6 s → p20 (tile c2), d2 at 99 s → p60 (tile c6).
        assert_eq!(plan.depth_of(&TileId { col: 0, row: 0 }), [0]);
        assert_eq!(plan.depth_of(&TileId { col: 2, row: 0 }), [1]);
        assert_eq!(plan.depth_of(&TileId { col: 6, row: 0 }), [2]);
        assert!(plan.depth_of(&TileId { col: 3, row: 0 }).is_empty());
    }

    #[test]
    fn the_plan_round_trips_through_json() {
        let panos: Vec<IndexRow> = (0..20).map(|i| row(&format!("p{i}"), f64::from(i) * 2.0)).collect();
        let plan = plan_campaign(&panos, &[], &drive(), &TilingParams::new(100.0, 10.0)).unwrap();
        let PlanDoc::V1(back) = serde_json::from_slice(&plan.to_json()).unwrap();
        assert_eq!(back, plan);
    }

    #[test]
    fn bad_tiling_parameters_are_an_error() {
        let panos = vec![row("p", 1.0)];
        assert!(plan_campaign(&panos, &[], &drive(), &TilingParams::new(0.0, 10.0)).is_err());
    }
}
