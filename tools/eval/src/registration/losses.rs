//! Where TRUE aerial correspondences are lost: every corner search of Jende et al. 2017 §3.8 scored against
//! the ground truth (the corner's true ground point projected into the aerial frame) and followed through
//! the NCC threshold, the per-image RANSAC, the cross-image consistency with the per-image minimum, and the
//! multi-image triangulation, per panorama fate. Part of `plumbline-eval registration`
//! (`cargo run --release -p plumbline-eval -- registration`; `--failed` lists the panoramas not matched).

use std::collections::{BTreeMap, BTreeSet};

use plumbline_geo::metrics;
use plumbline_registration::TileResultV1;
use plumbline_registration::aerial::ImageTrace;

use plumbline_fixtures::registration::Campaign;

/// A peak within this many aerial pixels of the true position is the true one (the report's criterion).
const TRUE_PX: f64 = 2.0;

/// Counts of corner searches (one corner in one aerial image) by what became of them.
#[derive(Clone, Default)]
pub struct Losses {
    /// Searches run.
    pub searches: usize,
    /// The true position lay outside the search window: the transfer (initial transformation) was off.
    pub outside: usize,
    /// The best placement lay on the window's border (no peak).
    pub border: usize,
    /// The peak was not the true position: accepted (a false match) / rejected by the NCC threshold.
    pub wrong_accepted: usize,
    pub wrong_rejected: usize,
    /// The peak was the true position but below the NCC threshold.
    pub true_below: usize,
    /// True matches: accepted; then lost in RANSAC; lost in the consistency / per-image minimum; kept.
    pub true_matched: usize,
    pub lost_ransac: usize,
    pub lost_consistency: usize,
    pub kept: usize,
    /// False matches kept to the end of §3.8.
    pub false_kept: usize,
    /// Kept true matches whose point ended in the tie output (triangulated, patch not discarded).
    pub in_output: usize,
    /// NCC coefficients of the true peaks.
    pub true_scores: Vec<f64>,
    /// Transfer errors (predicted − true, pixels) of searches whose image passed §3.7.
    pub transfer: Vec<f64>,
}

impl Losses {
    fn add(&mut self, trace: &ImageTrace, truth: &BTreeMap<usize, [f64; 2]>, output: &BTreeSet<usize>) {
        let (ransac, kept): (BTreeSet<usize>, BTreeSet<usize>) =
            (trace.ransac.iter().copied().collect(), trace.kept.iter().copied().collect());
        for a in &trace.attempts {
            let Some(t) = truth.get(&a.slot) else { continue };
            self.searches += 1;
            let near = |p: [f64; 2]| (p[0] - t[0]).hypot(p[1] - t[1]) <= TRUE_PX;
            let off = (a.predicted[0] - t[0]).abs().max((a.predicted[1] - t[1]).abs());
            self.transfer.push((a.predicted[0] - t[0]).hypot(a.predicted[1] - t[1]));
            let (Some(peak), Some(score)) = (a.peak, a.score) else {
                if off > trace.radius as f64 {
                    self.outside += 1
                } else {
                    self.border += 1
                }
                continue;
            };
            if !near(peak) {
                match a.matched {
                    _ if off > trace.radius as f64 => self.outside += 1,
                    Some(_) => self.wrong_accepted += 1,
                    None => self.wrong_rejected += 1,
                }
                if a.matched.is_some() && kept.contains(&a.slot) {
                    self.false_kept += 1;
                }
                continue;
            }
            self.true_scores.push(score);
            let Some(m) = a.matched else {
                self.true_below += 1;
                continue;
            };
            if !near(m) {
                self.wrong_accepted += 1;
                continue;
            }
            self.true_matched += 1;
            if !ransac.contains(&a.slot) {
                self.lost_ransac += 1;
            } else if !kept.contains(&a.slot) {
                self.lost_consistency += 1;
            } else {
                self.kept += 1;
                self.in_output += usize::from(output.contains(&a.slot));
            }
        }
    }
}

/// Losses per panorama fate (`matched` or the discard key) over the panoramas `marked` says have markings.
pub fn losses(
    campaign: &Campaign,
    result: &TileResultV1,
    traces: &[Vec<ImageTrace>],
    marked: &dyn Fn(&str) -> bool,
) -> BTreeMap<String, Losses> {
    let mut out: BTreeMap<String, Losses> = BTreeMap::new();
    for (d, traces) in result.images.iter().zip(traces).filter(|(d, _)| marked(&d.image)) {
        let fate = d.discarded.as_ref().map_or("matched".to_owned(), |r| r.key());
        let prefix = format!("{}:", d.image);
        let ties: Vec<_> = result.ties.iter().filter(|t| t.id.0.starts_with(&prefix)).collect();
        let slot = |id: &str| id[prefix.len()..].parse::<usize>().ok();
        let output: BTreeSet<usize> =
            ties.iter().filter(|t| t.aerial.is_some()).filter_map(|t| slot(&t.id.0)).collect();
        let grounds: Vec<_> = ties.iter().filter_map(|t| Some((slot(&t.id.0)?, campaign.true_ground(t)?))).collect();
        let entry = out.entry(fate).or_default();
        for trace in traces {
            let truth: BTreeMap<usize, [f64; 2]> =
                grounds.iter().filter_map(|(k, g)| Some((*k, campaign.aerial_pixel(&trace.frame, g)?))).collect();
            entry.add(trace, &truth, &output);
        }
    }
    out
}

/// Type-7 quantile `q` of `v` (NaN when empty), on a copy.
fn quantile(v: &[f64], q: f64) -> f64 {
    metrics::quantile(&mut v.to_vec(), q).unwrap_or(f64::NAN)
}

/// The table of [`losses`] for several profiles.
pub fn print(rows: &[(&str, BTreeMap<String, Losses>)]) {
    println!("\nWhere TRUE aerial correspondences are lost, panoramas WITH markings, by their fate: corner searches");
    println!("(one corner in one aerial image) scored against the truth (true ground point projected into the frame;");
    println!("true = within {TRUE_PX} px). outside = truth beyond the search window (transfer off); wrong = the NCC");
    println!("peak elsewhere (accepted / rejected by the threshold); below = true peak under the NCC threshold.");
    println!(
        "\n| profile | fate | searches | outside | border | wrong acc. / rej. | true below NCC | true matched | lost RANSAC | lost consistency/min. | true kept | in output | false kept | true NCC q10/q50 | transfer err. q50/q90 px |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for (name, map) in rows {
        for (fate, l) in map {
            println!(
                "| {name} | {fate} | {} | {} | {} | {} / {} | {} | {} | {} | {} | {} | {} | {} | {:.2}/{:.2} | {:.1}/{:.1} |",
                l.searches,
                l.outside,
                l.border,
                l.wrong_accepted,
                l.wrong_rejected,
                l.true_below,
                l.true_matched,
                l.lost_ransac,
                l.lost_consistency,
                l.kept,
                l.in_output,
                l.false_kept,
                quantile(&l.true_scores, 0.1),
                quantile(&l.true_scores, 0.5),
                quantile(&l.transfer, 0.5),
                quantile(&l.transfer, 0.9),
            );
        }
    }
}

/// The aerial points more than two aerial pixels off horizontally: tie id, horizontal and height error,
/// reported σ_H and the frames the point was triangulated from.
pub fn wrong_points(campaign: &Campaign, result: &TileResultV1, gsd: f64) -> Vec<String> {
    let frames: BTreeMap<&str, usize> =
        result.images.iter().flat_map(|d| d.aerial_frames.iter().map(|f| (f.tie.as_str(), f.frames.len()))).collect();
    result
        .ties
        .iter()
        .filter_map(|t| {
            let a = t.aerial.as_ref()?;
            let g = campaign.true_ground(t)?;
            let (dx, dy, dz) = (a.position[0] - g.x(), a.position[1] - g.y(), a.position[2] - g.z());
            (dx.hypot(dy) > TRUE_PX * gsd).then(|| {
                let n = frames.get(t.id.0.as_str()).copied().unwrap_or(0);
                let c = &a.covariance;
                let (h, s) = (dx.hypot(dy), horizontal_sigma(c));
                format!("{} {h:.2}/{dz:+.2}/{:.2} m σ_h {s:.3} m ×{n}", t.id.0, c[2][2].sqrt())
            })
        })
        .collect()
}

/// The largest horizontal standard deviation of a covariance (m): the root of the 2×2 block's largest
/// eigenvalue.
pub fn horizontal_sigma(c: &[[f64; 3]; 3]) -> f64 {
    let (m, d) = (0.5 * (c[0][0] + c[1][1]), 0.5 * (c[0][0] - c[1][1]));
    (m + d.hypot(c[0][1])).max(0.0).sqrt()
}

/// Quantiles 10/50/90/99 of the horizontal σ of all aerial points, m.
pub fn sigma_quantiles(result: &TileResultV1) -> [f64; 4] {
    let s: Vec<f64> =
        result.ties.iter().filter_map(|t| Some(horizontal_sigma(&t.aerial.as_ref()?.covariance))).collect();
    [0.1, 0.5, 0.9, 0.99].map(|q| quantile(&s, q))
}

/// Every panorama with markings that was not matched: id, fate, true DG error (E, N, m), reported σ, and per
/// aerial image its rejection, KAZE inliers, correlation NCC and offset (m).
pub fn failed_panoramas(campaign: &Campaign, result: &TileResultV1, marked: &dyn Fn(&str) -> bool) -> Vec<String> {
    result
        .images
        .iter()
        .filter(|d| marked(&d.image))
        .filter_map(|d| {
            let why = d.discarded.as_ref()?.key();
            let k = campaign.panoramas.iter().position(|p| p.id == d.image)?;
            let (p, (_, truth)) = (&campaign.panoramas[k], &campaign.truth[k]);
            let e = [p.pose.translation.x() - truth.translation.x(), p.pose.translation.y() - truth.translation.y()];
            let frames: Vec<String> = d
                .aerial_images
                .iter()
                .map(|a| {
                    let rejection = a.rejection.as_ref().map_or("ok".to_owned(), |r| format!("{r:?}"));
                    let ncc = a.fallback_ncc.map_or("–".to_owned(), |n| format!("{n:.2}"));
                    let off = a.offset_m.map_or("–".to_owned(), |o| format!("{o:.2}"));
                    format!("{} {rejection} kaze {} ncc {ncc} off {off}", a.frame, a.initial_inliers)
                })
                .collect();
            Some(format!(
                "{} {why} DG error {:+.2}/{:+.2} m σ {:.2} m; [{}]",
                d.image,
                e[0],
                e[1],
                p.position_sigma,
                frames.join("; ")
            ))
        })
        .collect()
}
