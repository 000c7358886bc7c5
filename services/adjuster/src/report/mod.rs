//! Filling the campaign report (`plumbline_report::Report`) from the campaign, the merged tiles and the
//! adjustment: summary, before/after against the reference, series, map, residuals, tiles, skipped items,
//! rejected observations and flagged epochs.

pub mod series;
mod warnings;

pub use warnings::input_warnings;

use std::collections::HashSet;

use plumbline_adjustment::{Adjustment, ObservationRef};
use plumbline_campaign::{Campaign, SkipReason, SkippedInput, Stage};
use plumbline_geo::Trajectory;
use plumbline_geo::metrics::compare;
use plumbline_report::{
    Accuracy, CampaignInfo, Figures, FlaggedEpoch, HeightBiasLine, RejectedObservation, Report, StageLine, Summary,
};

use crate::merge::Merged;
use crate::refs;
use crate::residuals::normalised_residuals;
use crate::solve::{Solved, panorama_mount};

/// The report of an adjusted campaign. `reference` (normally `campaign.reference`) gives the before/after
/// figures and the cross-track series; `stages` are listed as given.
pub fn build_report(
    campaign: &Campaign,
    merged: &Merged,
    solved: &Solved,
    reference: Option<&Trajectory>,
    stages: &[StageLine],
) -> Report {
    let dg = &campaign.trajectory.trajectory;
    let result = &solved.adjustment;
    let full = series::corrections(dg, &solved.corrected);
    let compared = reference.and_then(|r| match (compare(dg, r), compare(&solved.corrected, r)) {
        (Ok(before), Ok(after)) => Some((before, after)),
        (Err(e), _) | (_, Err(e)) => {
            tracing::warn!(error = %e, "no comparison with the reference trajectory");
            None
        }
    });
    let mount = panorama_mount(&campaign.manifest);
    Report {
        campaign: campaign_info(campaign),
        summary: summary(campaign, merged, solved, &full),
        accuracy: compared.as_ref().map(|(before, after)| Accuracy {
            reference: reference_name(campaign),
            before: Figures::from(before),
            after: Figures::from(after),
        }),
        correction: series::decimated(&full),
        cross_track: compared.as_ref().map(|(before, after)| series::cross_track(before, after)),
        map: series::map(&full, &solved.corrected, &campaign.plan.panoramas, merged),
        residuals: normalised_residuals(&merged.observations, result, dg, &mount),
        stages: stages.to_vec(),
        tiles: merged.tiles.clone(),
        skipped: skipped(campaign, merged, solved),
        rejected: rejected(merged, result),
        flags: flags(solved),
        height_biases: height_biases(result),
        road_lines: Vec::new(),
        road_line_panoramas: None,
        warnings: input_warnings(&campaign.manifest, merged),
    }
}

/// The adjustment's height bias per aerial frame set.
fn height_biases(result: &Adjustment) -> Vec<HeightBiasLine> {
    let line = |b: &plumbline_adjustment::HeightBias| HeightBiasLine {
        frames: b.frames.clone(),
        points: b.points,
        bias_m: b.bias,
        sigma_m: b.sigma,
        prior_sigma_m: b.prior_sigma,
    };
    result.height_biases.iter().map(line).collect()
}

fn campaign_info(campaign: &Campaign) -> CampaignInfo {
    CampaignInfo {
        id: campaign.manifest.campaign.id.to_string(),
        name: campaign.manifest.campaign.name.clone(),
        crs: campaign.epsg(),
        generated_by: format!("plumbline {}", env!("CARGO_PKG_VERSION")),
    }
}

/// The reference trajectory's URL as the manifest names it.
fn reference_name(campaign: &Campaign) -> String {
    let location = campaign.manifest.trajectory.first().and_then(|t| t.reference());
    location.map_or_else(String::new, |l| campaign.url(l).unwrap_or_else(|_| l.as_str().to_owned()))
}

/// How many distinct items of `kind` the adjustment skipped.
fn skipped_count(result: &Adjustment, kind: &str) -> usize {
    let owners: HashSet<(&str, usize)> = result.skipped.iter().map(|s| refs::owner(&s.item)).collect();
    owners.iter().filter(|(k, _)| *k == kind).count()
}

fn summary(
    campaign: &Campaign,
    merged: &Merged,
    solved: &Solved,
    full: &plumbline_report::CorrectionSeries,
) -> Summary {
    let records = solved.corrected.records();
    let (t0, t1) = solved.corrected.span();
    let length_m = records.windows(2).map(|w| (w[1].position - w[0].position).v.xy().norm()).sum();
    let obs = &merged.observations;
    let result = &solved.adjustment;
    Summary {
        epochs: records.len(),
        duration_s: t1 - t0,
        length_m,
        images: campaign.plan.panoramas.len(),
        images_matched: merged.images.iter().filter(|i| i.matched()).count(),
        ties: obs.ties.len() - skipped_count(result, "tie"),
        pole_updates: obs.poles.len() - skipped_count(result, "pole"),
        gnss: obs.gnss.len() - skipped_count(result, "gnss"),
        max_correction_m: full.east.iter().zip(&full.north).map(|(e, n)| e.hypot(*n)).fold(0.0, f64::max),
        sigma0: result.sigma0,
    }
}

/// Everything skipped: while loading, in the tiles (with the registration discards), by the consistency
/// check and by the adjustment.
fn skipped(campaign: &Campaign, merged: &Merged, solved: &Solved) -> Vec<SkippedInput> {
    let mut out: Vec<SkippedInput> = campaign.skipped.iter().chain(&merged.skipped).cloned().collect();
    out.extend(solved.consistency.skipped.iter().map(|(pair, e)| {
        SkippedInput::new(Stage::Consistency, format!("image pair {pair}"), SkipReason::Untestable, e.to_string())
    }));
    out.extend(solved.adjustment.skipped.iter().map(|s| {
        SkippedInput::new(
            Stage::Adjustment,
            format!("{} {}", refs::kind(&s.item), refs::id(&s.item)),
            SkipReason::BadField(s.field.to_string()),
            format!("{} {}: field `{}` {}", refs::kind(&s.item), refs::id(&s.item), s.field, s.problem),
        )
    }));
    out
}

/// The rejected observations; a whole tie point names the rejected part of it (same snooping round) that
/// left it undetermined — the adjustment drops such a point without testing it.
fn rejected(merged: &Merged, result: &Adjustment) -> Vec<RejectedObservation> {
    let follows = |r: &plumbline_adjustment::RejectedObservation| {
        let ObservationRef::Tie { index, .. } = &r.item else { return None };
        let part = |p: &&plumbline_adjustment::RejectedObservation| {
            p.round == r.round
                && matches!(&p.item, ObservationRef::TieRay { index: i, .. } | ObservationRef::TieAerial { index: i, .. } if i == index)
        };
        result.rejected.iter().find(part).map(|p| refs::id(&p.item))
    };
    result
        .rejected
        .iter()
        .map(|r| RejectedObservation {
            kind: refs::kind(&r.item).into(),
            id: refs::id(&r.item),
            time: refs::time(&merged.observations, &r.item).unwrap_or_default(),
            w_test: r.w,
            follows: follows(r),
        })
        .collect()
}

/// Flagged epochs: the consistency check's pairs (at the pair's start; the DG blamed), the standstills
/// whose zero-velocity constraint data snooping rejected (the vehicle moved although the DG says it stood)
/// and the DG jumps snooping found on the chain (`jump`, at the widened link's start).
pub fn flags(solved: &Solved) -> Vec<FlaggedEpoch> {
    let consistency = solved.consistency.flags.iter().map(|f| FlaggedEpoch {
        time: f.link.start,
        test: "consistency".into(),
        sensor: "dg".into(),
    });
    let standstills = solved.adjustment.standstills.iter().filter(|s| !s.accepted()).map(|s| FlaggedEpoch {
        time: s.standstill.start,
        test: "standstill".into(),
        sensor: "dg".into(),
    });
    let jumps = solved.adjustment.jumps.iter().map(|j| FlaggedEpoch {
        time: j.start,
        test: "jump".into(),
        sensor: "dg".into(),
    });
    consistency.chain(standstills).chain(jumps).collect()
}
