//! Step 1 (Jende et al. 2017 §3.2) and the KAZE features (§3.3) of one panorama at a time, so that a caller can
//! decode a panorama, prepare it and drop its pixels before the next: a tile's memory then holds ortho
//! patches, not full panoramas. Which panoramas need preparing follows from their DG poses alone.

use std::time::Instant;

use plumbline_geo::MapFromBody;
use plumbline_imaging::kaze::KazeFeatures;
use plumbline_imaging::{GrayImage, ImagePart};
use plumbline_lines::Stroke;
use rayon::prelude::*;

use super::pairing::neighbour;
use super::{PipelineConfig, StageTimings};
use crate::mm::{MmConfig, MmError, OrthoPatch, Panorama, PanoramaRig, features, ortho_patch};

/// What the pairing knows of a panorama before its pixels are read: id, time, DG pose, σ and whether the
/// tile registers it.
#[derive(Clone, Debug)]
pub struct PanoramaInfo {
    /// Image id (unique within the campaign).
    pub id: String,
    /// Exposure time on the trajectory's time scale, seconds.
    pub time: f64,
    /// The vehicle pose at `time` from direct georeferencing.
    pub pose: MapFromBody,
    /// 1σ horizontal uncertainty of the DG position, metres.
    pub position_sigma: f64,
    /// The vehicle's velocity at `time` from the trajectory, m/s ([`Panorama::velocity`]).
    pub velocity: Option<[f64; 3]>,
    /// True when the tile registers this panorama; false for a context panorama, which serves only as the
    /// neighbour of an owned one (it is registered by its own tile).
    pub owned: bool,
}

impl PanoramaInfo {
    /// The description of a decoded panorama.
    pub fn of(pano: &Panorama, owned: bool) -> Self {
        Self {
            id: pano.id.clone(),
            time: pano.time,
            pose: pano.pose,
            position_sigma: pano.position_sigma,
            velocity: pano.velocity,
            owned,
        }
    }
}

/// A panorama after step 1 and feature extraction: its ortho patch and KAZE features (or the error that
/// stopped them), without its pixels. A context panorama no owned one pairs with stays unprepared.
#[derive(Clone, Debug)]
pub struct PreparedPanorama {
    /// Id, time, pose and σ; `image` is an empty 0 × 0 placeholder (the pixels are dropped after step 1).
    pub(crate) pano: Panorama,
    pub(crate) owned: bool,
    /// `None`: not prepared.
    pub(crate) patch: Option<Result<(OrthoPatch, KazeFeatures), MmError>>,
    /// Road markings in its ortho patch (owned panoramas, when the extraction is on).
    pub(crate) strokes: Vec<Stroke>,
    pub(crate) timings: StageTimings,
}

impl PreparedPanorama {
    /// A panorama that is not prepared: a context panorama that no owned panorama pairs with. It keeps its
    /// place in the tile's time order (pairing looks at the panoramas next to an owned one).
    pub fn unprepared(info: PanoramaInfo) -> Self {
        let pano = Panorama {
            id: info.id,
            time: info.time,
            image: GrayImage::filled(0, 0, 0.0),
            part: ImagePart::whole(0, 0),
            pose: info.pose,
            position_sigma: info.position_sigma,
            velocity: info.velocity,
        };
        Self { pano, owned: info.owned, patch: None, strokes: Vec::new(), timings: StageTimings::default() }
    }

    /// Image id.
    pub fn id(&self) -> &str {
        &self.pano.id
    }

    /// Exposure time, seconds.
    pub fn time(&self) -> f64 {
        self.pano.time
    }

    /// The DG vehicle pose.
    pub fn pose(&self) -> &MapFromBody {
        &self.pano.pose
    }

    /// True when the tile registers it.
    pub fn owned(&self) -> bool {
        self.owned
    }

    /// True when step 1 and the features ran (successfully or not).
    pub fn is_prepared(&self) -> bool {
        self.patch.is_some()
    }

    /// The error of step 1 or of the features, if one stopped them.
    pub fn error(&self) -> Option<&MmError> {
        self.patch.as_ref().and_then(|p| p.as_ref().err())
    }

    /// Time spent in step 1 and the features.
    pub fn timings(&self) -> StageTimings {
        self.timings
    }

    /// The road-marking strokes of its ortho patch (owned panoramas with the extraction on), in map
    /// coordinates of the pose it was prepared with, cut to the camera's disc of `lines_max_distance`.
    pub fn strokes(&self) -> &[Stroke] {
        &self.strokes
    }

    /// Its ortho patch, while prepared (none before step 1, after [`PreparedPanorama::release`] or when
    /// step 1 failed).
    pub fn patch(&self) -> Option<&OrthoPatch> {
        match &self.patch {
            Some(Ok((patch, _))) => Some(patch),
            _ => None,
        }
    }

    /// Drop the ortho patch and features once no pair still to be registered needs them (a failed
    /// preparation keeps its error); the panorama keeps its place, pose and timings, and
    /// [`PreparedPanorama::is_prepared`] becomes false.
    pub fn release(&mut self) {
        if matches!(self.patch, Some(Ok(_))) {
            self.patch = None;
        }
    }
}

/// Step 1 and the KAZE features of one panorama (Jende et al. 2017 §3.2–§3.3). The result holds no pixels of the
/// panorama: the caller may drop it at once.
pub fn prepare_panorama(pano: &Panorama, owned: bool, rig: &PanoramaRig, config: &MmConfig) -> PreparedPanorama {
    let mut timings = StageTimings::default();
    let t0 = Instant::now();
    let patch = ortho_patch(pano, rig, config.gsd, config.half_extent);
    timings.ortho = t0.elapsed();
    let patch = patch.and_then(|patch| {
        let t1 = Instant::now();
        let f = features(&patch, &pano.id, config);
        timings.features = t1.elapsed();
        f.map(|f| (patch, f))
    });
    let mut prepared = PreparedPanorama::unprepared(PanoramaInfo::of(pano, owned));
    if let (true, Some(lines), Ok((patch, _))) = (owned, &config.lines, &patch) {
        let t2 = Instant::now();
        let camera = rig.mount.camera_pose(&pano.pose).translation;
        let strokes = plumbline_lines::extract(&patch.image, &patch.valid, &patch.grid, lines);
        prepared.strokes = within(strokes, [camera.x(), camera.y()], config.lines_max_distance);
        timings.lines = t2.elapsed();
    }
    prepared.patch = Some(patch);
    prepared.timings = timings;
    prepared
}

/// The strokes cut to the disc of `radius` around `centre`: each part inside becomes a stroke, ending on the
/// circle where the cut made it, that end open.
fn within(strokes: Vec<Stroke>, centre: [f64; 2], radius: f64) -> Vec<Stroke> {
    let inside = |p: [f64; 2]| (p[0] - centre[0]).hypot(p[1] - centre[1]) <= radius;
    // The point of segment a–b on the circle (a and b on either side of it), by bisection.
    let crossing = |a: [f64; 2], b: [f64; 2]| {
        let (mut lo, mut hi) = (0.0, 1.0);
        let at = |t: f64| [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t];
        for _ in 0..40 {
            let mid = 0.5 * (lo + hi);
            if inside(at(mid)) == inside(a) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        at(0.5 * (lo + hi))
    };
    let mut out = Vec::new();
    for s in strokes {
        let mut run: Vec<[f64; 2]> = Vec::new();
        let mut open_start = s.open[0];
        for (k, &p) in s.points.iter().enumerate() {
            let previous = k.checked_sub(1).map(|j| s.points[j]);
            match (inside(p), previous) {
                (true, Some(q)) if !inside(q) => {
                    run = vec![crossing(q, p), p];
                    open_start = true;
                }
                (true, _) => run.push(p),
                (false, Some(q)) if inside(q) => {
                    run.push(crossing(q, p));
                    if run.len() >= 2 {
                        out.push(Stroke { points: std::mem::take(&mut run), open: [open_start, true], ..s.clone() });
                    }
                    run.clear();
                }
                (false, _) => {}
            }
        }
        if run.len() >= 2 {
            out.push(Stroke { points: run, open: [open_start, s.open[1]], ..s.clone() });
        }
    }
    out
}

/// Every panorama prepared and owned, in parallel (for callers that hold the whole tile anyway).
pub fn prepare_panoramas(panoramas: &[Panorama], rig: &PanoramaRig, config: &MmConfig) -> Vec<PreparedPanorama> {
    panoramas.par_iter().map(|p| prepare_panorama(p, true, rig, config)).collect()
}

/// The indices of `items` in the order the tile processes them: by time, then id (`key` gives both).
pub fn time_order<T>(items: &[T], key: impl Fn(&T) -> (f64, &str)) -> Vec<usize> {
    let mut order: Vec<usize> = (0..items.len()).collect();
    order.sort_by(|&a, &b| {
        let (ka, kb) = (key(&items[a]), key(&items[b]));
        ka.0.total_cmp(&kb.0).then_with(|| ka.1.cmp(kb.1))
    });
    order
}

/// Which of `panoramas` must be prepared: every owned one and every context one that is the neighbour
/// ([`neighbour`]) of an owned one; the others can stay [`PreparedPanorama::unprepared`]. One flag
/// per panorama, in the given order. Pairing depends on the DG poses only, so this needs no pixels; a
/// panorama that later cannot be read must be left out and the question asked again.
pub fn panoramas_to_prepare(panoramas: &[PanoramaInfo], rig: &PanoramaRig, config: &PipelineConfig) -> Vec<bool> {
    let owned: Vec<&str> = panoramas.iter().filter(|p| p.owned).map(|p| p.id.as_str()).collect();
    panoramas_to_prepare_for(panoramas, &owned, rig, config)
}

/// [`panoramas_to_prepare`] for registering only the owned panoramas named in `ids`: those and their
/// neighbours.
pub fn panoramas_to_prepare_for(
    panoramas: &[PanoramaInfo],
    ids: &[&str],
    rig: &PanoramaRig,
    config: &PipelineConfig,
) -> Vec<bool> {
    let wanted: std::collections::HashSet<&str> = ids.iter().copied().collect();
    let registering = |p: &PanoramaInfo| p.owned && wanted.contains(p.id.as_str());
    let order = time_order(panoramas, |p| (p.time, p.id.as_str()));
    let poses: Vec<&MapFromBody> = order.iter().map(|&k| &panoramas[k].pose).collect();
    let mut needed: Vec<bool> = panoramas.iter().map(registering).collect();
    for (i, &k) in order.iter().enumerate() {
        if registering(&panoramas[k])
            && let Ok(j) = neighbour(i, &poses, rig, config)
        {
            needed[order[j]] = true;
        }
    }
    needed
}

#[cfg(test)]
mod within_tests {
    use super::*;

    fn stroke(points: Vec<[f64; 2]>) -> Stroke {
        Stroke { points, width_m: 0.12, sigma_m: 0.01, open: [false, false] }
    }

    #[test]
    fn strokes_are_cut_on_the_circle_and_the_cut_ends_open() {
        // Radius 10 around the origin: a line from x = −14 to 14 at y = 6 crosses it at x = ±8.
        let line = stroke(vec![[-14.0, 6.0], [-4.0, 6.0], [4.0, 6.0], [14.0, 6.0]]);
        let inside = stroke(vec![[1.0, 1.0], [2.0, 1.0]]);
        let outside = stroke(vec![[20.0, 0.0], [30.0, 0.0]]);
        let cut = within(vec![line, inside.clone(), outside], [0.0, 0.0], 10.0);
        assert_eq!(cut.len(), 2, "{cut:?}");
        let p = &cut[0].points;
        assert_eq!(p.len(), 4, "{p:?}");
        assert!((p[0][0] + 8.0).abs() < 1e-9 && (p[3][0] - 8.0).abs() < 1e-9, "{p:?}");
        assert_eq!(cut[0].open, [true, true]);
        assert_eq!(cut[1], inside, "a stroke inside stays as it was");
        // A two-point dash with one end outside keeps its inside part, open there.
        let dash = within(vec![stroke(vec![[9.0, 0.0], [12.0, 0.0]])], [0.0, 0.0], 10.0);
        assert_eq!(dash.len(), 1);
        assert!((dash[0].points[1][0] - 10.0).abs() < 1e-9 && dash[0].open == [false, true], "{dash:?}");
    }
}
