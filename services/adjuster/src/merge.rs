//! Merging the tiles' results into one observation set for the global adjustment, with what the report needs
//! from them: the image diagnostics, the pole frames, per-tile counts and every skipped item.

use std::collections::HashSet;

use plumbline_adjustment::ObservationSetV1;
use plumbline_geo::tiling::TileId;
use plumbline_navigation::ImageMotion;
use plumbline_poles::{FrameReport, FrameReportV1};
use plumbline_registration::TileResultV1;
use plumbline_report::TileLine;
use plumbline_scheduler::SkippedInput;
use plumbline_worker::TileOutputV1;

/// What became of one panorama in its tile's registration.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageOutcome {
    /// Panorama id.
    pub image: String,
    /// Exposure time, seconds.
    pub time: f64,
    /// The tile that registered it.
    pub tile: TileId,
    /// Why it produced no aerial points: the reason key (e.g. `aerial.too_few_plausible`) and the message;
    /// `None` when it was matched.
    pub discarded: Option<(String, String)>,
}

impl ImageOutcome {
    /// Whether the panorama gave aerial points.
    pub fn matched(&self) -> bool {
        self.discarded.is_none()
    }
}

/// The tiles' results merged.
#[derive(Clone, Debug, Default)]
pub struct Merged {
    /// Tie points and pole updates of all tiles (duplicated tie ids are kept once).
    pub observations: ObservationSetV1,
    /// Image-derived motions between neighbouring panoramas, for the consistency check.
    pub motions: Vec<ImageMotion>,
    /// One outcome per registered panorama, in tile order.
    pub images: Vec<ImageOutcome>,
    /// The pole frame reports of all tiles.
    pub pole_frames: Vec<FrameReportV1>,
    /// Per-tile counts, in tile order.
    pub tiles: Vec<TileLine>,
    /// Items the tiles skipped, registration discards (`registration`, `discard.<key>`) and duplicates.
    pub skipped: Vec<SkippedInput>,
}

/// The report's name of a tile: `c{col}_r{row}`.
pub fn tile_name(tile: &TileId) -> String {
    format!("c{}_r{}", tile.col, tile.row)
}

/// Merge the tiles' results (see [`Merged`]).
pub fn merge(tiles: &[TileOutputV1]) -> Merged {
    let mut out = Merged::default();
    let mut tie_ids = HashSet::new();
    let mut motion_pairs = HashSet::new();
    for t in tiles {
        let skipped_before = out.skipped.len();
        out.skipped.extend(t.skipped.iter().cloned());
        let (mut images, mut matched, mut ties) = (0, 0, 0);
        if let Some(reg) = &t.registration {
            let height_scale = shared_height_scale(reg);
            for tie in &reg.ties {
                if tie_ids.insert(tie.id.clone()) {
                    let mut tie = tie.clone();
                    if let Some(a) = tie.aerial.as_mut() {
                        scale_height(&mut a.covariance, height_scale);
                    }
                    out.observations.ties.push(tie);
                    ties += 1;
                } else {
                    out.skipped.push(duplicate_tie(&t.tile, &tie.id.0));
                }
            }
            for m in motions_of(reg) {
                // The last panorama of a tile pairs backwards with the one before: one motion per pair.
                if motion_pairs.insert((m.start.to_bits(), m.end.to_bits())) {
                    out.motions.push(m);
                }
            }
            images = reg.images.len();
            matched = reg.images.iter().filter(|d| d.discarded.is_none()).count();
            add_images(&mut out, &t.tile, reg);
        }
        out.observations.poles.extend(t.poles.iter().cloned());
        out.pole_frames.extend(t.pole_frames.iter().map(|FrameReport::V1(f)| f.clone()));
        let skipped = out.skipped.len() - skipped_before;
        let line = TileLine { tile: tile_name(&t.tile), images, matched, ties, poles: t.poles.len(), skipped };
        out.tiles.push(line);
    }
    out
}

/// The image diagnostics of one tile as outcomes, each discard also a skipped item.
fn add_images(out: &mut Merged, tile: &TileId, reg: &TileResultV1) {
    for d in &reg.images {
        let discarded = d.discarded.as_ref().map(|r| (r.key(), r.to_string()));
        if let Some((key, detail)) = &discarded {
            out.skipped.push(SkippedInput {
                stage: "registration".into(),
                item: d.image.clone(),
                reason: format!("discard.{key}"),
                detail: format!("panorama {} (tile {}): {detail}", d.image, tile_name(tile)),
            });
        }
        out.images.push(ImageOutcome { image: d.image.clone(), time: d.time, tile: *tile, discarded });
    }
}

/// The factor on the σ of the aerial heights of one tile's tie points. Paper 000 §3.9 triangulates each
/// point from the same few nadir frames of the tile's area, so the points share those frames' orientation
/// errors: with a base-to-height ratio of a few per cent, a 10 µrad relative attitude error moves every
/// height of the tile by decimetres while their horizontal positions move by millimetres. Weighting n such
/// heights as independent would let their common error pull the trajectory's height with √n times its
/// weight; scaling each height σ by √n gives the tile's heights together the weight of one point's.
fn shared_height_scale(reg: &TileResultV1) -> f64 {
    let n = reg.ties.iter().filter(|t| t.aerial.is_some()).count();
    (n.max(1) as f64).sqrt()
}

/// Scale the height row and column of a 3×3 covariance by `k` (D C D with D = diag(1, 1, k): stays SPD, keeps
/// the correlations).
fn scale_height(c: &mut [[f64; 3]; 3], k: f64) {
    for row in c.iter_mut() {
        row[2] *= k;
    }
    for v in c[2].iter_mut() {
        *v *= k;
    }
}

fn duplicate_tie(tile: &TileId, id: &str) -> SkippedInput {
    SkippedInput {
        stage: "adjustment".into(),
        item: id.to_owned(),
        reason: "duplicate_tie".into(),
        detail: format!("tie point {id} of tile {} already came from another tile; kept once", tile_name(tile)),
    }
}

/// The image-derived motions between neighbouring panoramas of a tile (paper 000 §3.3): each diagnostic's
/// motion to its neighbour, where KAZE + RANSAC measured one.
pub fn motions_of(result: &TileResultV1) -> Vec<ImageMotion> {
    result.images.iter().filter_map(|d| d.motion).collect()
}

#[cfg(test)]
mod tests {
    use super::scale_height;

    #[test]
    fn the_height_scaling_keeps_the_horizontal_block_and_the_correlations() {
        let mut c = [[0.04, 0.01, 0.02], [0.01, 0.09, -0.03], [0.02, -0.03, 2.25]];
        let before = c;
        scale_height(&mut c, 4.0_f64.sqrt());
        assert_eq!([c[0][0], c[0][1], c[1][0], c[1][1]], [before[0][0], before[0][1], before[1][0], before[1][1]]);
        assert!((c[2][2] - 4.0 * 2.25).abs() < 1e-12, "σz doubles for four points");
        let corr = |m: [[f64; 3]; 3], i: usize| m[i][2] / (m[i][i] * m[2][2]).sqrt();
        for i in 0..2 {
            assert!((corr(c, i) - corr(before, i)).abs() < 1e-12);
            assert_eq!(c[i][2], c[2][i]);
        }
    }
}
