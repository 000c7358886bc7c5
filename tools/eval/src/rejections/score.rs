//! Tie rays and aerial points scored against the truth: the true error of every observation in units of its
//! own σ, and the verdict on a rejected one. Part of `plumbline-eval rejections`.

use std::collections::{HashMap, HashSet};
use std::fmt;

use nalgebra::{Matrix2, Vector2, Vector3};
use plumbline_adjuster::{Merged, Solved};
use plumbline_adjustment::{ObservationRef, TieRay};
use plumbline_geo::metrics::quantile_sorted;
use plumbline_geo::{MapFromCamera, PositionInterpolation};

use super::truth::{CLASSES, Truth};

/// |error| / σ beyond which an observation is wrong in truth (the w-test's critical value at α = 0.1 %).
const WRONG: f64 = 3.29;

/// The true error of one tie ray: the angle between the observed direction and the direction from the true
/// camera to the tie's true point (that of the other ray for the first ray, of the first ray otherwise).
#[derive(Clone, Copy, Debug, Default)]
pub struct RayScore {
    /// Surface class under the ray.
    pub class: Option<u8>,
    /// Angle / σ.
    pub error: Option<f64>,
    /// Its component across the epipolar plane (camera centres and the true point) / σ: the part a
    /// two-ray intersection can detect; the rest moves the point along the rays.
    pub across: Option<f64>,
    /// Range from the camera to the true point, metres.
    pub range: Option<f64>,
    /// The signed angular error (observed − true, radians) along the ray's tangents [across, elevation]
    /// (`TieRay::tangents`), and the ray's σ along them.
    pub components: Option<[f64; 2]>,
    pub sigmas: [f64; 2],
    /// Height of the camera above the true point, metres.
    pub height: Option<f64>,
    /// Range from the other ray's camera to the true point, and the distance between the cameras, metres.
    pub other: Option<[f64; 2]>,
}

/// The geometry of one ray against the truth (see [`RayScore`]).
struct Geometry {
    error: f64,
    across: f64,
    range: f64,
    components: [f64; 2],
    height: f64,
    other: Option<[f64; 2]>,
}

/// Score `ray` seen from the true camera `pose` against the true point `p`; `other` is the other ray's camera.
fn geometry(ray: &TieRay, pose: &MapFromCamera, p: &Vector3<f64>, other: Option<&MapFromCamera>) -> Geometry {
    let r = pose.rotation.matrix();
    let observed = Vector3::from(ray.direction).normalize();
    let truly = r.transpose() * (p - pose.translation.p).normalize();
    let [t_across, t_elevation] = ray.tangents().map(Vector3::from);
    let d = observed - truly;
    let sigmas = ray.sigmas();
    let components = [d.dot(&t_across), d.dot(&t_elevation)];
    let error = (components[0] / sigmas[0]).hypot(components[1] / sigmas[1]);
    // The part across the epipolar plane (camera centres and the true point), over σ in that direction.
    let base = other.map(|o| r.transpose() * (o.translation.p - pose.translation.p)).unwrap_or_default();
    let normal = base.cross(&truly).try_normalize(1e-9).unwrap_or_default();
    let (na, ne) = (normal.dot(&t_across), normal.dot(&t_elevation));
    let sigma_n = ((na * sigmas[0]).powi(2) + (ne * sigmas[1]).powi(2)).sqrt() / na.hypot(ne).max(1e-12);
    let range = (p - pose.translation.p).norm();
    let height = pose.translation.p.z - p.z;
    let other = other.map(|o| [(p - o.translation.p).norm(), (o.translation.p - pose.translation.p).norm()]);
    Geometry { error, across: observed.dot(&normal).abs() / sigma_n, range, components, height, other }
}

/// The true error of one aerial point against the surface point of its tie's first ray.
#[derive(Clone, Copy, Debug)]
pub struct AerialScore {
    /// Surface class of that point.
    pub class: u8,
    /// Horizontal error: its Mahalanobis norm under the horizontal covariance.
    pub horizontal: f64,
    /// Height error (aerial − true), metres, and the point's height σ.
    pub height_m: f64,
    pub height_sigma: f64,
}

/// What a rejected observation is in truth.
pub enum Verdict {
    /// Within its σ of the truth.
    Correct,
    /// Wrong beyond its σ.
    Wrong(String),
    /// Rejected because another part of it was.
    Consequence(String),
    /// Not scored.
    Unknown(String),
}

impl fmt::Display for Verdict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Correct => write!(f, "correct"),
            Self::Wrong(s) => write!(f, "wrong: {s}"),
            Self::Consequence(s) | Self::Unknown(s) => write!(f, "{s}"),
        }
    }
}

/// Every tie of a merged set scored.
pub struct Scores {
    pub rays: Vec<Vec<RayScore>>,
    pub aerial: Vec<Option<AerialScore>>,
    /// The true body position at each panorama time (bits of the time → position).
    positions: HashMap<u64, Vector3<f64>>,
}

fn class_name(c: Option<u8>) -> &'static str {
    c.and_then(|c| CLASSES.get(usize::from(c)).copied()).unwrap_or("nothing")
}

impl Scores {
    /// Score every tie of `merged`.
    pub fn of(merged: &Merged, truth: &mut Truth) -> Self {
        let mut rays = Vec::new();
        let mut aerial = Vec::new();
        let mut positions = HashMap::new();
        for tie in &merged.observations.ties {
            let hits: Vec<_> = tie.rays.iter().map(|r| truth.hit(r.time, r.direction)).collect();
            let mut scores = Vec::new();
            for (k, ray) in tie.rays.iter().enumerate() {
                let reference = if k == 0 { hits.get(1).copied().flatten() } else { hits[0] };
                let other = truth.camera_at(tie.rays[usize::from(k == 0)].time);
                let g = reference
                    .zip(truth.camera_at(ray.time))
                    .map(|(p, pose)| geometry(ray, &pose, &p.point, other.as_ref()));
                if let Some(image) = truth.image_at(ray.time) {
                    positions.insert(ray.time.to_bits(), image.body.translation.p);
                }
                scores.push(RayScore {
                    class: hits[k].map(|h| h.class),
                    error: g.as_ref().map(|g| g.error),
                    across: g.as_ref().map(|g| g.across),
                    range: g.as_ref().map(|g| g.range),
                    components: g.as_ref().map(|g| g.components),
                    sigmas: ray.sigmas(),
                    height: g.as_ref().map(|g| g.height),
                    other: g.as_ref().and_then(|g| g.other),
                });
            }
            rays.push(scores);
            aerial.push(tie.aerial.zip(hits.first().copied().flatten()).map(|(a, hit)| {
                let d = Vector3::from(a.position) - hit.point;
                let c = Matrix2::new(a.covariance[0][0], a.covariance[0][1], a.covariance[1][0], a.covariance[1][1]);
                let dh = Vector2::new(d.x, d.y);
                let horizontal = c.try_inverse().map_or(f64::NAN, |inv| (dh.transpose() * inv * dh)[0].sqrt());
                AerialScore { class: hit.class, horizontal, height_m: d.z, height_sigma: a.covariance[2][2].sqrt() }
            }));
        }
        Self { rays, aerial, positions }
    }

    /// A rejected ray's verdict.
    pub fn ray_verdict(&self, tie: usize, ray: usize) -> Verdict {
        let s = self.rays[tie][ray];
        match s.error {
            None => Verdict::Unknown("no truth under the rays".into()),
            Some(e) if e > WRONG => Verdict::Wrong(format!("ray to a {} point", class_name(s.class))),
            Some(_) => Verdict::Correct,
        }
    }

    /// A rejected aerial point's verdict: horizontally wrong, wrong in height beyond the shared error of the
    /// points of its ties' frames, or correct.
    pub fn aerial_verdict(&self, tie: usize) -> Verdict {
        let Some(a) = self.aerial[tie] else { return Verdict::Unknown("no truth under the first ray".into()) };
        let on = class_name(Some(a.class));
        if a.horizontal > WRONG {
            Verdict::Wrong(format!("aerial position of a {on} point off horizontally"))
        } else if a.height_m.abs() > WRONG * a.height_sigma {
            Verdict::Wrong(format!("aerial height of a {on} point off"))
        } else {
            Verdict::Correct
        }
    }

    /// A whole tie's verdict: its worst part.
    pub fn tie_verdict(&self, tie: usize) -> Verdict {
        let worst =
            (0..self.rays[tie].len()).map(|k| self.ray_verdict(tie, k)).find(|v| matches!(v, Verdict::Wrong(_)));
        worst.unwrap_or_else(|| if self.aerial[tie].is_some() { self.aerial_verdict(tie) } else { Verdict::Correct })
    }

    /// The corrected trajectory's horizontal error at a panorama time, metres (NaN elsewhere).
    pub fn trajectory_error(&self, solved: &Solved, t: f64) -> f64 {
        let Some(truth) = self.positions.get(&t.to_bits()) else { return f64::NAN };
        let Ok(rec) = solved.corrected.interpolate(t, PositionInterpolation::Linear) else { return f64::NAN };
        (rec.position.p - truth).xy().norm()
    }

    /// The rejected (tie, ray) pairs and the ties whose aerial point was rejected.
    pub fn rejected(&self, solved: &Solved) -> (HashSet<(usize, usize)>, HashSet<usize>) {
        let mut rejected_rays = HashSet::new();
        let mut rejected_aerial = HashSet::new();
        for r in &solved.adjustment.rejected {
            match &r.item {
                ObservationRef::TieRay { index, ray, .. } => _ = rejected_rays.insert((*index, *ray)),
                ObservationRef::TieAerial { index, .. } => _ = rejected_aerial.insert(*index),
                ObservationRef::Tie { index, .. } => {
                    rejected_aerial.insert(*index);
                    rejected_rays.extend((0..self.rays[*index].len()).map(|k| (*index, k)));
                }
                _ => {}
            }
        }
        (rejected_rays, rejected_aerial)
    }

    /// The true errors of accepted and rejected rays and aerial points.
    pub fn print_distributions(&self, solved: &Solved) {
        let (rejected_rays, rejected_aerial) = self.rejected(solved);
        let mut rays: [Vec<f64>; 2] = Default::default();
        for (i, tie) in self.rays.iter().enumerate() {
            for (k, s) in tie.iter().enumerate() {
                if let Some(e) = s.error {
                    rays[usize::from(rejected_rays.contains(&(i, k)))].push(e);
                }
            }
        }
        let [mut horizontal, mut height, mut height_m]: [Accepted; 3] = Default::default();
        for (i, a) in self.aerial.iter().enumerate() {
            let Some(a) = a else { continue };
            let k = usize::from(rejected_aerial.contains(&i));
            horizontal[k].push(a.horizontal);
            height[k].push(a.height_m.abs() / a.height_sigma);
            height_m[k].push(a.height_m.abs());
        }
        println!("| true error | set | n | median | 95 % | max | share > {WRONG} | RMS per component |");
        println!("|---|---|---|---|---|---|---|---|");
        let lines = [
            ("ray angle / σ", &rays, 2.0),
            ("aerial horizontal (Mahalanobis)", &horizontal, 2.0),
            ("aerial height / σ", &height, 1.0),
        ];
        for (what, sets, dof) in lines {
            for (set, values) in ["accepted", "rejected"].iter().zip(sets.iter()) {
                println!("| {what} | {set} | {} |", stats(values, dof));
            }
        }
        for (set, values) in ["accepted", "rejected"].iter().zip(height_m.iter()) {
            let mut v = values.clone();
            v.sort_by(f64::total_cmp);
            println!(
                "| aerial height error, m | {set} | {} | {:.3} | {:.3} | {:.3} | | |",
                v.len(),
                q(&v, 0.5),
                q(&v, 0.95),
                q(&v, 1.0)
            );
        }
        println!();
    }

    /// The second rays' true errors by the surface class under the first ray, in bands of |error| / σ, with
    /// the self-check of the truth: a direction computed from the truth reads back its own point.
    pub fn print_by_class(&self) {
        const BANDS: [f64; 5] = [1.0, 2.0, WRONG, 10.0, 100.0];
        let mut by: std::collections::BTreeMap<&str, [usize; 6]> = Default::default();
        for tie in &self.rays {
            let (Some(first), Some(e)) = (tie[0].class, tie.get(1).and_then(|r| r.error)) else { continue };
            let band = BANDS.iter().position(|b| e <= *b).unwrap_or(BANDS.len());
            by.entry(class_name(Some(first))).or_default()[band] += 1;
        }
        println!(
            "| second ray, range to the point | n | median / σ | across the epipolar plane: median | 95 % | share > {WRONG} |"
        );
        println!("|---|---|---|---|---|---|");
        for (lo, hi) in [(0.0, 5.0), (5.0, 8.0), (8.0, 12.0), (12.0, 20.0), (20.0, f64::INFINITY)] {
            let in_band = |r: &&RayScore| r.range.is_some_and(|x| (lo..hi).contains(&x));
            let band: Vec<&RayScore> = self.rays.iter().filter_map(|t| t.get(1)).filter(in_band).collect();
            let mut all: Vec<f64> = band.iter().filter_map(|r| r.error).collect();
            let mut across: Vec<f64> = band.iter().filter_map(|r| r.across).collect();
            all.sort_by(f64::total_cmp);
            across.sort_by(f64::total_cmp);
            let beyond = across.iter().filter(|e| **e > WRONG).count() as f64 / across.len().max(1) as f64;
            println!(
                "| {lo}–{hi} m | {} | {:.2} | {:.2} | {:.2} | {:.1} % |",
                all.len(),
                q(&all, 0.5),
                q(&across, 0.5),
                q(&across, 0.95),
                100.0 * beyond
            );
        }
        println!();
        println!("| first ray on | ≤ 1σ | 1–2σ | 2–3.29σ | 3.29–10σ | 10–100σ | > 100σ |");
        println!("|---|---|---|---|---|---|---|");
        for (class, n) in by {
            println!("| {class} | {} | {} | {} | {} | {} | {} |", n[0], n[1], n[2], n[3], n[4], n[5]);
        }
        println!();
    }

    /// Per aerial frame set: the estimated height bias against the mean true height error of its points.
    pub fn print_height_biases(&self, merged: &Merged, solved: &Solved) {
        let index: HashMap<&str, usize> =
            merged.observations.ties.iter().enumerate().map(|(i, t)| (t.id.0.as_str(), i)).collect();
        println!(
            "| frame set | points | estimated bias | σ | true mean height error | its spread (SD) | median point σ_z |"
        );
        println!("|---|---|---|---|---|---|---|");
        for set in &merged.observations.aerial_frame_sets {
            let errors: Vec<(f64, f64)> = set
                .ties
                .iter()
                .filter_map(|id| index.get(id.0.as_str()).and_then(|&i| self.aerial[i]))
                .map(|a| (a.height_m, a.height_sigma))
                .collect();
            let n = errors.len().max(1) as f64;
            let mean = errors.iter().map(|e| e.0).sum::<f64>() / n;
            let sd = (errors.iter().map(|e| (e.0 - mean).powi(2)).sum::<f64>() / n).sqrt();
            let mut sigmas: Vec<f64> = errors.iter().map(|e| e.1).collect();
            sigmas.sort_by(f64::total_cmp);
            let estimated = solved.adjustment.height_biases.iter().find(|b| b.frames == set.frames);
            let (bias, sigma) = estimated.map_or((f64::NAN, f64::NAN), |b| (b.bias, b.sigma));
            println!(
                "| {} | {} | {bias:+.3} | {sigma:.3} | {mean:+.3} | {sd:.3} | {:.3} |",
                set.frames.join("+"),
                errors.len(),
                q(&sigmas, 0.5)
            );
        }
        println!();
    }
}

/// Values of accepted (`[0]`) and rejected (`[1]`) observations.
type Accepted = [Vec<f64>; 2];

/// Type-7 quantile of sorted values, NaN when empty.
fn q(sorted: &[f64], p: f64) -> f64 {
    quantile_sorted(sorted, p).unwrap_or(f64::NAN)
}

/// `n | median | 95 % | max | share beyond | RMS per component` of |normalised errors| of `dof` components.
fn stats(values: &[f64], dof: f64) -> String {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let beyond = v.iter().filter(|e| **e > WRONG).count() as f64 / v.len().max(1) as f64;
    let rms = (v.iter().map(|e| e * e).sum::<f64>() / (dof * v.len().max(1) as f64)).sqrt();
    format!(
        "{} | {:.2} | {:.2} | {:.2} | {:.1} % | {rms:.2}",
        v.len(),
        q(&v, 0.5),
        q(&v, 0.95),
        q(&v, 1.0),
        100.0 * beyond
    )
}
