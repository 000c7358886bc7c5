//! Scoring a pipeline run against the synthetic truth: detection recall of observable cadastre poles,
//! matching precision, and the χ² test of the CUPT residuals against the stated error model.
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

use std::collections::{BTreeMap, BTreeSet, HashMap};

use plumbline_geo::{Camera, Map, Point3, Vec3};
use plumbline_poles::{FrameReport, PoleOutput};
use plumbline_synth::cadastre::Defect;

use super::Scenario;

/// The figures of a run.
#[derive(Debug, Default)]
pub struct Score {
    /// Observable / detected cadastre poles (lights, signs, traffic lights: the "poles" of Meyer et al. 2023).
    pub observable: usize,
    pub detected: usize,
    /// Observable / detected trees (Meyer et al. 2023 keep them apart: no diameter, leaning, crowns).
    pub trees_observable: usize,
    pub trees_detected: usize,
    pub matched_poles: usize,
    pub matches: usize,
    pub wrong: usize,
    pub updates: usize,
    pub poles_with_updates: usize,
    /// Σ over poles of |mean residual|² / its variance, with the stated model scaled by 1, 2, 1/2.
    pub chi2: [f64; 3],
    pub dof: usize,
    pub frames: usize,
}

impl Score {
    pub fn recall(&self) -> f64 {
        self.detected as f64 / self.observable.max(1) as f64
    }
    pub fn precision(&self) -> f64 {
        1.0 - self.wrong as f64 / self.matches.max(1) as f64
    }
}

/// Upper and lower χ² quantiles (Wilson–Hilferty) at two-sided level 1 %.
pub fn chi2_bounds(dof: usize) -> (f64, f64) {
    let k = dof as f64;
    let z = 2.5758;
    let q = |z: f64| k * (1.0 - 2.0 / (9.0 * k) + z * (2.0 / (9.0 * k)).sqrt()).powi(3);
    (q(-z), q(z))
}

impl Scenario {
    /// Where a point observed with the DG pose of frame `i` truly lies (same camera-frame vector, true pose).
    pub fn to_truth(&self, i: usize, p: [f64; 2], height: f64) -> [f64; 2] {
        let dg = self.shots[i].dg.pose();
        let truth = self.shots[i].truth.pose();
        let r: Vec3<Camera> = self.mount.to_camera(&dg, &Point3::<Map>::new(p[0], p[1], height));
        let t = self.mount.georeference(&truth, &r, 1.0);
        [t.x(), t.y()]
    }

    /// The world pole within 0.5 m of a truly-located point.
    pub fn world_pole(&self, p: [f64; 2]) -> Option<u32> {
        self.world
            .poles
            .iter()
            .map(|q| ((q.base[0] - p[0]).hypot(q.base[1] - p[1]), q.id))
            .filter(|(d, _)| *d < 0.5)
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .map(|(_, id)| id)
    }

    /// Score a run whose frame `k` is shot `k`.
    pub fn score(&self, out: &PoleOutput) -> Score {
        let by_key: HashMap<String, &plumbline_synth::cadastre::CadastreObject> =
            self.cadastre.iter().filter_map(|o| o.cadastre_id.map(|id| (format!("0:{id}"), o))).collect();
        let index: HashMap<&str, usize> = self.shots.iter().enumerate().map(|(i, s)| (s.id.as_str(), i)).collect();
        let mut s = Score::default();
        let mut observable: BTreeSet<u32> = BTreeSet::new();
        let (mut detected, mut matched) = (BTreeSet::new(), BTreeSet::new());
        for report in &out.reports {
            let FrameReport::V1(r) = report;
            let i = index[r.frame.as_str()];
            s.frames += 1;
            let visible: BTreeSet<u32> = self
                .visible(i, 10.0)
                .into_iter()
                .filter(|id| self.cadastre.iter().any(|o| o.world_id == Some(*id) && o.defect == Defect::None))
                .collect();
            let height = r.ground_height_m.unwrap_or(0.0) + 1.5;
            let truth_of: Vec<Option<u32>> =
                r.detections.iter().map(|d| self.world_pole(self.to_truth(i, d.centre, height))).collect();
            for id in truth_of.iter().flatten() {
                if visible.contains(id) {
                    detected.insert(*id);
                }
            }
            observable.extend(visible);
            for m in &r.matches {
                s.matches += 1;
                let listed = by_key[&m.cadastre_id];
                if listed.world_id.is_none() || listed.world_id != truth_of[m.detection] {
                    s.wrong += 1;
                    if std::env::var("POLE_DEBUG").is_ok() {
                        let shot = &self.shots[i];
                        let err = (shot.dg.position.p - shot.truth.position.p).xy().norm();
                        println!(
                            "wrong: frame {} det {:?} (range {:.2} reliable {} diameter {:.2} slices {} extent {:?}) truth {:?} cadastre {:?} ({:?}) defect {:?} support {} offset {:?} dg err {err:.2} σ {:?}",
                            r.frame,
                            r.detections[m.detection].centre,
                            r.detections[m.detection].range_m,
                            r.detections[m.detection].reliable,
                            r.detections[m.detection].diameter_m,
                            r.detections[m.detection].slices,
                            r.detections[m.detection].height_extent_m,
                            truth_of[m.detection],
                            listed.world_id,
                            listed.class,
                            listed.defect,
                            r.support,
                            r.offset,
                            shot.dg.std.map(|s| s.east)
                        );
                    }
                } else if let Some(id) = listed.world_id {
                    matched.insert(id);
                }
            }
        }
        let is_tree = |id: &u32| self.world.poles[*id as usize].class == plumbline_synth::world::PoleClass::Tree;
        s.trees_observable = observable.iter().filter(|id| is_tree(id)).count();
        s.trees_detected = observable.intersection(&detected).filter(|id| is_tree(id)).count();
        observable.retain(|id| !is_tree(id));
        s.observable = observable.len();
        if std::env::var("POLE_DEBUG").is_ok() {
            for id in observable.difference(&detected) {
                let p = &self.world.poles[*id as usize];
                if p.class == plumbline_synth::world::PoleClass::Tree {
                    continue;
                }
                let frames: Vec<usize> =
                    (0..self.shots.len()).filter(|&i| self.visible(i, 10.0).contains(id)).collect();
                println!(
                    "missed pole {id} {:?} d {:.2} lean {:?} crown {:.1} frames {frames:?}",
                    p.class, p.diameter, p.lean, p.crown
                );
            }
        }
        s.detected = detected.intersection(&observable).count();
        s.matched_poles = matched.intersection(&observable).count();
        self.chi2(out, &mut s);
        s
    }

    fn chi2(&self, out: &PoleOutput, s: &mut Score) {
        let times: BTreeMap<u64, usize> =
            self.shots.iter().enumerate().map(|(i, shot)| (shot.time.to_bits(), i)).collect();
        // Per pole: residuals cadastre − truly-located observation, and the stated variances.
        let mut per_pole: BTreeMap<String, Vec<([f64; 2], f64, f64)>> = BTreeMap::new();
        for u in &out.updates {
            let i = times[&u.time.to_bits()];
            let z = self.world.config.ground_height + 1.5;
            let t = self.to_truth(i, u.observed, z);
            let r = [u.cadastre[0] - t[0], u.cadastre[1] - t[1]];
            per_pole.entry(u.cadastre_id.clone()).or_default().push((r, u.sigma_camera, u.sigma_pole));
        }
        s.updates = out.updates.len();
        s.poles_with_updates = per_pole.len();
        s.dof = 2 * per_pole.len();
        for (k, scale) in [1.0, 2.0, 0.5].into_iter().enumerate() {
            s.chi2[k] = per_pole
                .values()
                .map(|rs| {
                    let m = rs.len() as f64;
                    let mean = rs.iter().fold([0.0; 2], |a, (r, _, _)| [a[0] + r[0] / m, a[1] + r[1] / m]);
                    let cam = rs.iter().map(|(_, c, _)| c * c).sum::<f64>() / m;
                    // The cadastre error is shared by all of a pole's updates; the camera errors are not.
                    let var = scale * scale * (rs[0].2.powi(2) + cam / m);
                    (mean[0].powi(2) + mean[1].powi(2)) / var
                })
                .sum();
        }
    }
}
