//! What a tile's result depends on, as one SHA-256: a finished tile is reused (resumed, redelivered, or
//! after a resubmission) only when its output carries the fingerprint of the inputs and parameters it would
//! be computed from now. A resubmitted manifest with other registration or pole parameters, another
//! trajectory, other images or aerial orientations thus reprocesses the tiles they touch, and only those:
//! the adjustment's parameters, the campaign's name and its output are not part of it.
//!
//! In it: the worker's version; the manifest's sections the tile stage reads (CRS, panoramas, depth
//! cameras, point clouds, aerial reference, cadastres, tiling, registration and pole parameters, as
//! resolved JSON); the tile's plan (its owned and context panoramas, pairs, boxes) with every planned image
//! it reads (id, time, file) and the DG pose at each image's time; the aerial frames' orientations; the
//! worker configuration. Not in it: the bytes of the files the manifest and index rows name — a file
//! replaced under the same name is not noticed (give it a new name, or run with `--fresh`).

use plumbline_campaign::Campaign;
use plumbline_geo::tiling::TileId;
use plumbline_geo::trajectory::PositionInterpolation;
use sha2::{Digest as _, Sha256};

use crate::WorkerConfig;

/// The fingerprint of `tile` of `campaign` under `config`, as lowercase hex.
pub fn fingerprint(campaign: &Campaign, tile: &TileId, config: &WorkerConfig) -> String {
    let mut hash = Sha256::new();
    let mut part = |label: &str, bytes: &[u8]| {
        // Length-prefixed, so that no two different sequences of parts hash alike.
        hash.update(label.as_bytes());
        hash.update((bytes.len() as u64).to_le_bytes());
        hash.update(bytes);
    };
    part("version", env!("CARGO_PKG_VERSION").as_bytes());
    part("tile", format!("{}_{}", tile.col, tile.row).as_bytes());
    let m = &campaign.manifest;
    let sections = serde_json::json!({
        "crs": m.crs,
        "panoramas": m.panoramas,
        "depth": m.depth,
        "point_clouds": m.point_clouds,
        "aerial": m.aerial,
        "cadastres": m.cadastres,
        "tiling": m.tiling,
        "registration": m.parameters.registration,
        "poles": m.parameters.poles,
    });
    part("manifest", sections.to_string().as_bytes());
    let plan = &campaign.plan;
    let planned = plan.tiles.tile(tile);
    part("plan", format!("{planned:?}").as_bytes());
    let trajectory = &campaign.trajectory.trajectory;
    let pose = |time: f64| format!("{:?}", trajectory.interpolate(time, PositionInterpolation::default()).ok());
    let panoramas = planned.into_iter().flat_map(|t| t.owned.iter().chain(&t.context));
    for image in panoramas.filter_map(|id| usize::try_from(id.0).ok().and_then(|i| plan.panoramas.get(i))) {
        part("panorama", format!("{image:?} {}", pose(image.time)).as_bytes());
    }
    for image in plan.depth_of(tile).iter().filter_map(|&i| plan.depth.get(i)) {
        part("depth", format!("{image:?} {}", pose(image.time)).as_bytes());
    }
    part("aerial frames", format!("{:?}", campaign.aerial_frames).as_bytes());
    part("config", format!("{:?} {:?}", config.registration, config.poles).as_bytes());
    hash.finalize().iter().map(|b| format!("{b:02x}")).collect()
}
