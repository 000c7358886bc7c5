//! The road-line product: every panorama's marking strokes placed with the corrected trajectory (the
//! adjustment's correction at the panorama's time moves and turns them; its posterior covariance and the
//! extraction's own σ give each vertex's σ), then linked across panoramas into pieces and lines
//! ([`plumbline_lines::assemble`]). The same strokes placed with the DG trajectory alone give the lines a
//! mapping without the correction would have produced, for comparison.

use std::collections::HashSet;

use nalgebra::{Matrix6, Vector3, Vector6};
use plumbline_geo::{PositionInterpolation, Trajectory, TrajectoryRecord};
use plumbline_lines::{AssembleConfig, Assembly, Observed, RoadLine};
use plumbline_report::{MapLine, Report, RoadLineKind, RoadLinePanoramas};
use plumbline_runtime::gdal_write::{FieldType, FieldValue, LineFeature, LineLayer};

use crate::merge::Merged;
use crate::solve::Solved;

/// The lines placed with the corrected and with the DG trajectory.
#[derive(Clone, Debug, Default)]
pub struct RoadLines {
    /// Placed with the corrected trajectory.
    pub corrected: Assembly,
    /// Placed with the DG trajectory (its σ from the DG's own standard deviations).
    pub dg: Assembly,
    /// The corrected position (easting, northing) of the body at each panorama whose strokes were placed:
    /// where the drive could see paint from.
    pub centres: Vec<[f64; 2]>,
    /// Panoramas whose strokes were placed.
    pub panoramas: usize,
    /// Strokes placed.
    pub strokes: usize,
    /// Panoramas with strokes that could not be placed (their time outside the trajectory).
    pub unplaced: usize,
    /// Registered panoramas whose ortho patch gave no stroke (skipped: no paint in view or kept).
    pub without_strokes: usize,
}

/// Place every panorama's strokes with the corrected and with the DG trajectory and assemble both.
/// `ground_below_body` is the ground's depth under the body origin, metres (the lever of the correction's
/// roll and pitch on the ground points; a few millimetres either way).
pub fn road_lines(dg: &Trajectory, merged: &Merged, solved: &Solved, ground_below_body: f64) -> RoadLines {
    let mut corrected = Vec::new();
    let mut original = Vec::new();
    let (mut panoramas, mut strokes, mut unplaced) = (0, 0, 0);
    let mut centres = Vec::new();
    for (k, p) in merged.strokes.iter().enumerate() {
        let Ok(record) = dg.interpolate(p.time, PositionInterpolation::Linear) else {
            unplaced += 1;
            continue;
        };
        let (delta, covariance) =
            solved.adjustment.correction_at(p.time).unwrap_or((Vector6::zeros(), Matrix6::zeros()));
        panoramas += 1;
        centres.push([record.position.x() + delta[0], record.position.y() + delta[1]]);
        for s in &p.strokes {
            strokes += 1;
            corrected.push(place(s, k, &record, &delta, &covariance, ground_below_body));
            original.push(place_dg(s, k, &record));
        }
    }
    let config = AssembleConfig::default();
    RoadLines {
        corrected: plumbline_lines::assemble(&corrected, &config),
        dg: plumbline_lines::assemble(&original, &config),
        centres,
        panoramas,
        strokes,
        unplaced,
        without_strokes: without_strokes(merged),
    }
}

/// How many registered panoramas (each once, whichever tiles registered it) gave no stroke.
fn without_strokes(merged: &Merged) -> usize {
    let stroked: HashSet<&str> = merged.strokes.iter().map(|p| p.image.as_str()).collect();
    let registered: HashSet<&str> = merged.images.iter().map(|o| o.image.as_str()).collect();
    registered.difference(&stroked).count()
}

/// A stroke moved by the correction `delta` = [δp; δθ] (map frame) about the body origin of `record`: a
/// ground point x goes to x + δp + δθ × (x − p); its σ² is the extraction's plus the correction's
/// horizontal variance at that point (position, and heading times the lever).
fn place(
    s: &plumbline_lines::Stroke,
    panorama: usize,
    record: &TrajectoryRecord,
    delta: &Vector6<f64>,
    covariance: &Matrix6<f64>,
    ground_below_body: f64,
) -> Observed {
    let p = record.position;
    let (dp, dtheta) = (Vector3::new(delta[0], delta[1], delta[2]), Vector3::new(delta[3], delta[4], delta[5]));
    let mut worst = 0.0_f64;
    let points = s
        .points
        .iter()
        .map(|x| {
            let r = Vector3::new(x[0] - p.x(), x[1] - p.y(), -ground_below_body);
            let moved = dp + dtheta.cross(&r);
            // Horizontal variance: position block plus the heading's lever (its cross-covariance ignored).
            let lever2 = r.x * r.x + r.y * r.y;
            let var = 0.5 * (covariance[(0, 0)] + covariance[(1, 1)]) + covariance[(5, 5)] * lever2;
            worst = worst.max(var);
            [x[0] + moved.x, x[1] + moved.y]
        })
        .collect();
    Observed {
        points,
        width_m: s.width_m,
        sigma_m: (s.sigma_m * s.sigma_m + worst.max(0.0)).sqrt(),
        common_sigma_m: worst.max(0.0).sqrt(),
        open: s.open,
        panorama,
        heading: record.attitude.heading,
    }
}

/// A stroke as the DG placed it, σ from the DG's horizontal standard deviation (0 when it has none).
fn place_dg(s: &plumbline_lines::Stroke, panorama: usize, record: &TrajectoryRecord) -> Observed {
    let var = record.std.map_or(0.0, |d| 0.5 * (d.east * d.east + d.north * d.north));
    Observed {
        points: s.points.clone(),
        width_m: s.width_m,
        sigma_m: (s.sigma_m * s.sigma_m + var).sqrt(),
        common_sigma_m: var.sqrt(),
        open: s.open,
        panorama,
        heading: record.attitude.heading,
    }
}

/// Names of the line layers of `observations.gpkg`: the lines placed with the corrected trajectory and
/// with the DG trajectory.
pub const LINE_LAYERS: [&str; 2] = ["road_lines", "road_lines_dg"];

/// The line layers (names in [`LINE_LAYERS`]): one feature per road line with its kind, painted width,
/// dash pattern, length, σ (largest and per vertex) and how many pieces and panoramas gave it.
pub fn line_layers(lines: &RoadLines) -> Vec<LineLayer> {
    [(LINE_LAYERS[0], &lines.corrected), (LINE_LAYERS[1], &lines.dg)]
        .into_iter()
        .map(|(name, assembly)| LineLayer {
            name: name.to_owned(),
            fields: LINE_FIELDS.iter().map(|(n, t)| ((*n).to_owned(), *t)).collect(),
            features: assembly.lines.iter().filter(|l| l.vertices.len() >= 2).map(feature).collect(),
        })
        .collect()
}

const LINE_FIELDS: [(&str, FieldType); 10] = [
    ("kind", FieldType::Text),
    ("width_m", FieldType::Real),
    ("length_m", FieldType::Real),
    ("dash_m", FieldType::Real),
    ("gap_m", FieldType::Real),
    ("dashes", FieldType::Integer),
    ("sigma_m", FieldType::Real),
    ("sigma_vertices_m", FieldType::Text),
    ("pieces", FieldType::Integer),
    ("panoramas", FieldType::Integer),
];

fn feature(l: &RoadLine) -> LineFeature {
    let length: f64 = l.vertices.windows(2).map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1])).sum();
    let sigma = l.sigma_m.iter().copied().fold(0.0, f64::max);
    let vertices: Vec<String> = l.sigma_m.iter().map(|s| format!("{s:.3}")).collect();
    let count = |n: usize| FieldValue::Integer(i64::try_from(n).unwrap_or(i64::MAX));
    let (dash, gap, dashes) = l.dash.map_or((f64::NAN, f64::NAN, 0), |d| (d.dash_m, d.gap_m, d.dashes));
    let values = vec![
        FieldValue::Text(l.kind.as_str().to_owned()),
        FieldValue::Real(l.width_m),
        FieldValue::Real(length),
        FieldValue::Real(dash),
        FieldValue::Real(gap),
        count(dashes),
        FieldValue::Real(sigma),
        FieldValue::Text(vertices.join(",")),
        count(l.pieces.len()),
        count(l.panoramas),
    ];
    LineFeature { points: l.vertices.clone(), values }
}

/// The report's share of the lines: the corrected lines on the map, and per kind their count, length and
/// median vertex σ.
pub fn fill_report(report: &mut Report, lines: &RoadLines) {
    let assembly = &lines.corrected;
    report.map.lines = assembly
        .lines
        .iter()
        .map(|l| MapLine { kind: l.kind.as_str().to_owned(), points: l.vertices.clone() })
        .collect();
    let mut kinds: Vec<RoadLineKind> = Vec::new();
    let mut sigmas: Vec<Vec<f64>> = Vec::new();
    for l in &assembly.lines {
        let kind = l.kind.as_str();
        let k = match kinds.iter().position(|s| s.kind == kind) {
            Some(k) => k,
            None => {
                kinds.push(RoadLineKind { kind: kind.to_owned(), ..RoadLineKind::default() });
                sigmas.push(Vec::new());
                kinds.len() - 1
            }
        };
        kinds[k].lines += 1;
        kinds[k].length_m += l.vertices.windows(2).map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1])).sum::<f64>();
        sigmas[k].extend(l.sigma_m.iter().copied().filter(|s| s.is_finite()));
    }
    for (kind, mut s) in kinds.iter_mut().zip(sigmas) {
        s.sort_by(f64::total_cmp);
        kind.median_sigma_m = plumbline_geo::metrics::quantile_sorted(&s, 0.5).unwrap_or(f64::NAN);
    }
    report.road_lines = kinds;
    report.road_line_panoramas = (lines.panoramas + lines.unplaced > 0).then_some(RoadLinePanoramas {
        with_strokes: lines.panoramas,
        without_strokes: lines.without_strokes,
        unplaced: lines.unplaced,
    });
}

/// How far the ground lies below the body origin: the panorama camera's height above the road minus its
/// height above the body origin (the mount's lever arm points down in z); 2 m where the manifest does not
/// say (it only sets the lever of roll and pitch corrections: millimetres).
pub fn ground_below_body(manifest: &plumbline_campaign::ManifestV1) -> f64 {
    let p = manifest.panoramas.as_ref();
    p.and_then(|p| p.camera_height_m.map(|h| h + p.mount.lever_arm_m[2])).unwrap_or(2.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use plumbline_geo::{Attitude, Point3, PoseStd};

    fn record() -> TrajectoryRecord {
        let std = PoseStd { east: 0.3, north: 0.4, height: 0.5, roll: 0.001, pitch: 0.001, heading: 0.002 };
        TrajectoryRecord {
            time: 10.0,
            position: Point3::new(100.0, 200.0, 12.0),
            attitude: Attitude::new(0.0, 0.0, 0.5),
            std: Some(std),
        }
    }

    fn stroke() -> plumbline_lines::Stroke {
        plumbline_lines::Stroke {
            points: vec![[100.0, 200.0], [104.0, 203.0]],
            width_m: 0.12,
            sigma_m: 0.01,
            open: [false, true],
        }
    }

    #[test]
    fn a_stroke_moves_and_turns_with_the_correction_and_its_sigma_grows_with_the_lever() {
        // Shift (0.1, −0.2), turn 10 mrad about up (anticlockwise), 1 mm² position variance, 1e-6 rad² heading.
        let delta = Vector6::new(0.1, -0.2, 0.05, 0.0, 0.0, 0.01);
        let mut cov = Matrix6::zeros();
        cov[(0, 0)] = 1e-6;
        cov[(1, 1)] = 1e-6;
        cov[(5, 5)] = 1e-6;
        let o = place(&stroke(), 3, &record(), &delta, &cov, 1.9);
        // Under the body the point only shifts; 5 m away (4, 3) it also turns by 10 mrad × (−3, 4).
        assert!((o.points[0][0] - 100.1).abs() < 1e-12 && (o.points[0][1] - 199.8).abs() < 1e-12, "{:?}", o.points);
        assert!((o.points[1][0] - (104.1 - 0.03)).abs() < 1e-12, "{:?}", o.points);
        assert!((o.points[1][1] - (202.8 + 0.04)).abs() < 1e-12, "{:?}", o.points);
        // σ² = extraction 1e-4 + position 1e-6 + heading 1e-6 × 25 m² at the far vertex.
        assert!((o.sigma_m - (1e-4 + 1e-6 + 25e-6_f64).sqrt()).abs() < 1e-12, "{}", o.sigma_m);
        assert_eq!((o.panorama, o.open, o.heading), (3, [false, true], 0.5));
    }

    #[test]
    fn panoramas_without_strokes_are_counted_once() {
        use crate::merge::{ImageOutcome, PanoramaStrokes};
        let outcome = |image: &str, col| ImageOutcome {
            image: image.to_owned(),
            time: 0.0,
            tile: plumbline_geo::tiling::TileId { col, row: 0 },
            discarded: None,
        };
        // p1 registered by two tiles, p2 with strokes, p3 without.
        let mut merged = Merged {
            images: vec![outcome("p1", 0), outcome("p1", 1), outcome("p2", 0), outcome("p3", 1)],
            strokes: vec![PanoramaStrokes { image: "p2".into(), time: 0.0, strokes: vec![stroke()] }],
            ..Merged::default()
        };
        assert_eq!(without_strokes(&merged), 2);
        merged.strokes.push(PanoramaStrokes { image: "p1".into(), time: 0.0, strokes: vec![stroke()] });
        assert_eq!(without_strokes(&merged), 1);
    }

    #[test]
    fn the_dg_placement_keeps_the_points_and_takes_the_dg_sigma() {
        let o = place_dg(&stroke(), 0, &record());
        assert_eq!(o.points, stroke().points);
        // σ² = 1e-4 + (0.3² + 0.4²) / 2.
        assert!((o.sigma_m - (1e-4 + 0.125_f64).sqrt()).abs() < 1e-12, "{}", o.sigma_m);
    }
}
