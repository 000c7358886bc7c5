//! The cross-panorama check (Jende et al. 2017 §3.9) scored against the truth: per matched panorama, its aerial
//! offset against minus its true DG error (the offset is aerial − MM, the MM points carry the DG error), so
//! the bench shows whether the check flags wrong registrations or right ones, and which wrong ones it missed
//! and why (no partner: the nearest matched panoramas and where the image-motion chain to them breaks), and
//! how far off the image motions it marked contradicted truly are. Part of `plumbline-eval registration`
//! (`--offsets` lists every checked panorama).

use plumbline_geo::metrics::median;
use plumbline_registration::output::{CrossCheck, ImageDiagnostic};
use plumbline_registration::pipeline::crosscheck::{self, CrossCheckConfig, Link, Offset, Verdict};
use plumbline_registration::{PipelineConfig, TileResultV1};

use plumbline_fixtures::registration::{AERIAL_GSD, Campaign};

/// The check's outcome on one profile.
#[derive(Default)]
pub struct Scored {
    /// Panoramas with an aerial offset that the check ruled on (matched or flagged).
    pub checked: usize,
    /// Flagged as inconsistent.
    pub flagged: usize,
    /// Flagged and truly wrong (registration error above 2 aerial pixels).
    pub flagged_wrong: usize,
    /// Kept although truly wrong.
    pub kept_wrong: usize,
    /// Kept, unverified (no partner).
    pub unverified: usize,
    /// Image motions marked contradicted, and how far each truly is off (horizontal, m).
    pub contradicted: Vec<(String, f64)>,
    /// One line per flagged or truly wrong panorama.
    pub lines: Vec<String>,
    /// Over the comparisons of kept panoramas (re-run on the result): the largest residual / tolerance, and
    /// the largest residual (m).
    pub margin: (f64, f64),
}

/// Score `result`'s verdicts against the campaign's truth; `all`: one line per checked panorama with its
/// offset against the truth (`--offsets`), else only the flagged or truly wrong ones.
pub fn score(campaign: &Campaign, result: &TileResultV1, all: bool) -> Scored {
    let mut s = Scored::default();
    let errors = campaign.aerial_errors(result);
    let aerial_ties = result.ties.iter().filter(|t| t.aerial.is_some());
    let owner: Vec<&str> = aerial_ties.map(|t| t.id.0.split(':').next().unwrap_or("")).collect();
    let with_motion = result.images.iter().filter(|d| d.motion.is_some());
    for (d, m) in with_motion.zip(campaign.motion_checks(result)).filter(|(d, _)| d.motion_contradicted) {
        s.contradicted.push((d.image.clone(), m.error[0].hypot(m.error[1])));
    }
    for (k, d) in result.images.iter().enumerate() {
        let Some(offset) = d.aerial_offset else { continue };
        let flagged = d.discarded.as_ref().is_some_and(|r| r.key() == "inconsistent");
        if !(flagged || d.discarded.is_none()) {
            continue;
        }
        let e = dg_error(campaign, &d.image);
        let error = (offset.offset[0] + e[0]).hypot(offset.offset[1] + e[1]);
        let wrong = error > 2.0 * AERIAL_GSD;
        s.checked += 1;
        s.flagged += usize::from(flagged);
        s.flagged_wrong += usize::from(flagged && wrong);
        s.kept_wrong += usize::from(!flagged && wrong);
        s.unverified += usize::from(!flagged && d.cross_check == Some(CrossCheck::Unverified));
        let mine: Vec<&[f64; 3]> =
            owner.iter().zip(&errors).filter(|(o, _)| **o == d.image).map(|(_, e)| &e.0).collect();
        let median = |c: usize| {
            let mut v: Vec<f64> = mine.iter().map(|e| e[c]).collect();
            median(&mut v).unwrap_or(f64::NAN)
        };
        if all {
            let truth = format!("aerial − true median E {:+.3} N {:+.3} ({} points)", median(0), median(1), mine.len());
            let (o, minus_e) = (offset.offset, [-e[0], -e[1]]);
            s.lines.push(format!(
                "{}: offset {o:+.3?} σ {:.3?} n {}, −true DG error {minus_e:+.3?}, |offset + DG error| {error:.3}; {truth}; {}",
                d.image,
                offset.std,
                offset.points,
                verdict(d)
            ));
        }
        if !all && (flagged || wrong) {
            let fate = if flagged { "FLAGGED" } else { "kept" };
            s.lines.push(format!(
                "{} {fate} ({}): offset E {:+.2} N {:+.2} ± {:.3}/{:.3} m, −true DG error E {:+.2} N {:+.2}, registration error {error:.2} m; {}; {}",
                d.image,
                if wrong { "truly wrong" } else { "truly right" },
                offset.offset[0],
                offset.offset[1],
                offset.std[0],
                offset.std[1],
                -e[0],
                -e[1],
                verdict(d),
                reach(&result.images, k),
            ));
        }
    }
    s.margin = margin(campaign, result, &PipelineConfig::default().cross_check);
    s
}

/// The check re-run on the kept panoramas of `result` (all owned, in time order): how close the agreeing
/// comparisons come to their bound.
fn margin(campaign: &Campaign, result: &TileResultV1, config: &CrossCheckConfig) -> (f64, f64) {
    let images = &result.images;
    let offsets: Vec<Option<Offset>> = images
        .iter()
        .map(|d| d.aerial_offset.filter(|_| d.discarded.is_none()).map(|o| Offset { value: o.offset, std: o.std }))
        .collect();
    let dg = |id: &str| {
        campaign.panoramas.iter().find(|p| p.id == id).map(|p| [p.pose.translation.x(), p.pose.translation.y()])
    };
    let links: Vec<Option<Link>> = images
        .windows(2)
        .map(|w| {
            let of = |d: &ImageDiagnostic, other: &str| d.motion.filter(|_| d.neighbour.as_deref() == Some(other));
            let motion = of(&w[0], &w[1].image).or_else(|| of(&w[1], &w[0].image))?;
            Some(Link::of(&motion, dg(&w[0].image)?, dg(&w[1].image)?))
        })
        .collect();
    let kept = crosscheck::check(&offsets, &links, config).verdicts;
    let comparisons = kept.iter().filter_map(|v| if let Verdict::Kept(c) = v { Some(c) } else { None }).flatten();
    comparisons.fold((0.0, 0.0), |(r, m), c| (f64::max(r, c.residual_m / c.tolerance_m), f64::max(m, c.residual_m)))
}

/// The true horizontal DG error (DG − true body position) of panorama `id`.
fn dg_error(campaign: &Campaign, id: &str) -> [f64; 2] {
    let dg = campaign.panoramas.iter().find(|p| p.id == id).map(|p| p.pose.translation);
    let truth = campaign.truth.iter().find(|(t, _)| t == id).map(|(_, p)| p.translation);
    match (dg, truth) {
        (Some(d), Some(t)) => [d.x() - t.x(), d.y() - t.y()],
        _ => [f64::NAN; 2],
    }
}

fn verdict(d: &ImageDiagnostic) -> String {
    match (&d.discarded, &d.cross_check) {
        (Some(reason), _) => reason.to_string(),
        (None, Some(CrossCheck::Compared { agreeing, disagreeing })) => {
            format!("agrees with [{}], disagrees with [{}]", agreeing.join(" "), disagreeing.join(" "))
        }
        (None, Some(CrossCheck::Unverified)) => "unverified (no partner)".into(),
        (None, None) => "not checked".into(),
    }
}

/// The nearest matched panoramas before and after panorama `k` (in time order) and whether the image motion
/// links every consecutive pair between them (the first missing link named).
fn reach(images: &[ImageDiagnostic], k: usize) -> String {
    let matched = |i: usize| images[i].discarded.is_none() && images[i].aerial_offset.is_some();
    let linked = |i: usize| {
        let (a, b) = (&images[i], &images[i + 1]);
        (a.neighbour.as_deref() == Some(b.image.as_str()) && a.motion.is_some())
            || (b.neighbour.as_deref() == Some(a.image.as_str()) && b.motion.is_some())
    };
    let describe = |other: Option<usize>| {
        let Some(o) = other else { return "none".to_owned() };
        let (lo, hi) = (o.min(k), o.max(k));
        let broken = (lo..hi).find(|&i| !linked(i));
        let chain = broken.map_or("chain unbroken".to_owned(), |i| {
            format!("chain breaks at {}–{}", images[i].image, images[i + 1].image)
        });
        format!("{} ({} links, {chain})", images[o].image, hi - lo)
    };
    let before = (0..k).rev().find(|&i| matched(i));
    let after = (k + 1..images.len()).find(|&i| matched(i));
    format!("nearest matched: before {}, after {}", describe(before), describe(after))
}
