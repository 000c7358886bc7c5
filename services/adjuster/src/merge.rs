//! Merging the tiles' results into one observation set for the global adjustment, with what the report needs
//! from them: the image diagnostics, the pole frames, per-tile counts and every skipped item.

use std::collections::{BTreeMap, HashSet};

use plumbline_adjustment::{AerialFrameSet, ObservationSetV1, TiePoint, TiePointId};
use plumbline_campaign::{SkipReason, SkippedInput, Stage};
use plumbline_geo::tiling::TileId;
use plumbline_navigation::ImageMotion;
use plumbline_poles::{FrameReport, FrameReportV1};
use plumbline_registration::TileResultV1;
use plumbline_report::TileLine;
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
    /// Tie points and pole updates of all tiles (duplicated tie ids are kept once), and the aerial frame sets
    /// their aerial coordinates came from (one height bias each in the adjustment).
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
    /// The road markings each registered panorama's ortho patch showed, in DG map coordinates, in tile
    /// order (a panorama once).
    pub strokes: Vec<PanoramaStrokes>,
}

/// The road-marking strokes of one panorama.
#[derive(Clone, Debug, PartialEq)]
pub struct PanoramaStrokes {
    /// Panorama id.
    pub image: String,
    /// Exposure time, seconds.
    pub time: f64,
    /// The strokes, in the DG map coordinates of its ortho patch.
    pub strokes: Vec<plumbline_lines::Stroke>,
}

/// The report's name of a tile: `c{col}_r{row}`.
pub fn tile_name(tile: &TileId) -> String {
    format!("c{}_r{}", tile.col, tile.row)
}

/// Merge the tiles' results (see [`Merged`]).
pub fn merge(tiles: &[TileOutputV1]) -> Merged {
    let mut out = Merged::default();
    let mut stroked = HashSet::new();
    let mut tie_ids = HashSet::new();
    let mut motion_pairs = HashSet::new();
    let mut frame_sets: BTreeMap<Vec<String>, Vec<TiePointId>> = BTreeMap::new();
    for t in tiles {
        let skipped_before = out.skipped.len();
        out.skipped.extend(t.skipped.iter().cloned());
        let (mut images, mut matched, mut ties) = (0, 0, 0);
        if let Some(reg) = &t.registration {
            for tie in &reg.ties {
                if tie_ids.insert(tie.id.clone()) {
                    if let Some(frames) = frames_of(reg, tie) {
                        frame_sets.entry(frames).or_default().push(tie.id.clone());
                    }
                    out.observations.ties.push(tie.clone());
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
            add_images(&mut out, &t.tile, reg, &mut stroked);
        }
        out.observations.poles.extend(t.poles.iter().cloned());
        out.pole_frames.extend(t.pole_frames.iter().map(|FrameReport::V1(f)| f.clone()));
        let skipped = out.skipped.len() - skipped_before;
        let line = TileLine { tile: tile_name(&t.tile), images, matched, ties, poles: t.poles.len(), skipped };
        out.tiles.push(line);
    }
    out.observations.aerial_frame_sets =
        frame_sets.into_iter().map(|(frames, ties)| AerialFrameSet { frames, ties }).collect();
    out
}

/// The aerial frames a tie's coordinates were triangulated from, sorted: those the registration recorded for
/// it (`aerial_frames` of its first panorama's diagnostic), or — in results written before that was recorded
/// — the frames that gave correspondences to that panorama's patch (Jende et al. 2017 §3.8). `None` without aerial
/// coordinates or without such frames.
fn frames_of(reg: &TileResultV1, tie: &TiePoint) -> Option<Vec<String>> {
    tie.aerial.as_ref()?;
    let first = tie.rays.first()?.time;
    let diagnostic = reg.images.iter().find(|d| d.time == first)?;
    if let Some(recorded) = diagnostic.aerial_frames.iter().find(|f| f.tie == tie.id.0) {
        let mut frames = recorded.frames.clone();
        frames.sort();
        frames.dedup();
        return (!frames.is_empty()).then_some(frames);
    }
    let used = diagnostic.aerial_images.iter().filter(|a| a.rejection.is_none() && a.correspondences > 0);
    let mut frames: Vec<String> = used.map(|a| a.frame.clone()).collect();
    frames.sort();
    (!frames.is_empty()).then_some(frames)
}

/// The image diagnostics of one tile as outcomes, each discard also a skipped item; the strokes of a panorama
/// not in `stroked` (ids whose strokes are already in) are taken.
fn add_images(out: &mut Merged, tile: &TileId, reg: &TileResultV1, stroked: &mut HashSet<String>) {
    for d in &reg.images {
        let discarded = d.discarded.as_ref().map(|r| (r.key(), r.to_string()));
        if let Some((key, detail)) = &discarded {
            let detail = format!("panorama {} (tile {}): {detail}", d.image, tile_name(tile));
            let reason = SkipReason::Discarded(key.clone());
            out.skipped.push(SkippedInput::new(Stage::Registration, d.image.clone(), reason, detail));
        }
        out.images.push(ImageOutcome { image: d.image.clone(), time: d.time, tile: *tile, discarded });
        if !d.strokes.is_empty() && stroked.insert(d.image.clone()) {
            out.strokes.push(PanoramaStrokes { image: d.image.clone(), time: d.time, strokes: d.strokes.clone() });
        }
    }
}

fn duplicate_tie(tile: &TileId, id: &str) -> SkippedInput {
    let detail = format!("tie point {id} of tile {} already came from another tile; kept once", tile_name(tile));
    SkippedInput::new(Stage::Adjustment, id, SkipReason::DuplicateTie, detail)
}

/// The image-derived motions between neighbouring panoramas of a tile (Jende et al. 2017 §3.3): each diagnostic's
/// motion to its neighbour, where KAZE + RANSAC measured one and the registration's cross-panorama check
/// (Jende et al. 2017 §3.9) did not find it contradicted by the aerial offsets on both sides.
pub fn motions_of(result: &TileResultV1) -> Vec<ImageMotion> {
    result.images.iter().filter(|d| !d.motion_contradicted).filter_map(|d| d.motion).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The golden tile result (one tie with aerial coordinates, from a panorama matched in aerial0024 and
    /// aerial0025) as a tile output.
    fn output(result: TileResultV1) -> TileOutputV1 {
        let (tile, registration) = (result.tile, Some(result));
        TileOutputV1 {
            tile,
            registration,
            poles: vec![],
            pole_frames: vec![],
            skipped: vec![],
            seconds: vec![],
            fingerprint: None,
        }
    }

    fn golden() -> TileResultV1 {
        let text = plumbline_testkit::schemas::example("tile-result.v1.json");
        serde_json::from_str::<plumbline_registration::TileResult>(&text).expect("example parses").into_latest()
    }

    #[test]
    fn a_motion_the_cross_check_contradicted_is_not_used() {
        let mut result = golden();
        let motion =
            ImageMotion { start: 1.0, end: 1.5, displacement: [4.0, 0.5], heading_change: 0.0, std: [0.01; 3] };
        let template = result.images[0].clone();
        result.images = (0..3)
            .map(|k| {
                let mut d = template.clone();
                d.motion = Some(ImageMotion { start: k as f64, end: k as f64 + 0.5, ..motion });
                d.motion_contradicted = k == 1;
                d
            })
            .collect();
        let starts: Vec<f64> = motions_of(&result).iter().map(|m| m.start).collect();
        assert_eq!(starts, vec![0.0, 2.0]);
    }

    #[test]
    fn a_tie_is_grouped_by_its_recorded_frames_and_older_results_by_the_panorama_frames() {
        let mut result = golden();
        let id = result.ties[0].id.clone();
        result.images[0].aerial_frames[0].frames = vec!["aerial0031".into(), "aerial0025".into()];
        let sets = merge(&[output(result.clone())]).observations.aerial_frame_sets;
        assert_eq!(sets.len(), 1);
        assert_eq!(
            (sets[0].frames.clone(), sets[0].ties.clone()),
            (vec!["aerial0025".into(), "aerial0031".into()], vec![id.clone()])
        );
        // Without the record (results written before it existed): the frames that gave the panorama's patch
        // correspondences.
        result.images[0].aerial_frames.clear();
        let sets = merge(&[output(result)]).observations.aerial_frame_sets;
        assert_eq!(
            (sets[0].frames.clone(), sets[0].ties.clone()),
            (vec!["aerial0024".into(), "aerial0025".into()], vec![id])
        );
    }
}
