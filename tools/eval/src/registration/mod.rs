//! Registration accuracy on a synthetic campaign, per GNSS profile, in the form of Jende et al. (2017),
//! Table 1: images, images matched, correspondences, share correct (aerial position within 2 aerial pixels of
//! the true point, horizontally), why images failed, where true correspondences were lost (module `losses`:
//! every corner search of §3.8 scored against the truth), the points that are not correct, and the time per
//! stage per panorama.
//!
//! Run: `cargo run --release -p plumbline-eval -- registration [FLAGS]`, e.g.
//! `cargo run --release -p plumbline-eval -- registration --preset district --realism harsh --profiles canyon`.
//! Flags (defaults in parentheses): `--preset tiny|district` (tiny), `--length` route metres (400), `--spacing`
//! metres between panoramas (5), `--width` panorama pixels (1024), `--seed` (1), `--profiles` a comma list of
//! `open`, `urban`, `canyon`, `mixed` (`open,urban,canyon`); `--motion-pairs` prints every pair's image-derived
//! motion error, `--failed` lists every panorama with markings that was not matched with each aerial image's
//! fate, `--offsets` lists every checked panorama's aerial offset against the truth.
//! `--realism ideal|default|harsh` (ideal) renders the campaign through the simulator's sensor realism;
//! `--nuisances` then also runs it with each nuisance switched off in turn and prints one summary row per
//! variant, so the cost of each is visible (`--nuisances seams,JPEG`: only the rows whose names contain one
//! of the words). `--level-plane` ortho-projects on the level plane even where the world has relief (no
//! terrain model). For experiments, these override the `PipelineConfig` defaults (unset: the default):
//! the aerial matching (§3.8) `--min-ncc`, `--template-half`, `--search-radius`, `--dg-search true|false`,
//! `--min-roundness` (0: output edge points too); the initial transformation (§3.7) `--initial-candidates`,
//! `--min-initial-inliers`, `--pool-windows true|false`; `--min-mm-points`, `--max-height-offset`; `--crosscheck false` turns the
//! cross-panorama check off. The timing alone: `cargo bench -p plumbline-registration --bench registration`.
//! The panoramas are rendered once per realism variant: the images depend on the true drive alone, so each
//! further profile re-uses them with its own DG poses.

mod diagnosis;
mod heights;
mod losses;
mod motion;

use std::collections::BTreeMap;
use std::time::Instant;

use clap::ValueEnum;
use diagnosis::{MARKINGS_MIN_M2, Split};
use plumbline_fixtures::registration::{AERIAL_GSD, Campaign, MotionCheck, Profile, Spec};
use plumbline_geo::metrics::median;
use plumbline_geo::tiling::TileId;
use plumbline_registration::mm::TransformSource;
use plumbline_registration::pipeline::prepare_panoramas;
use plumbline_registration::{PipelineConfig, StageTimings, register_tile};
use plumbline_synth::render::{Radiometry, Realism, RealismLevel, Rig};
use plumbline_synth::world::{self, EpochChanges, Relief};

/// The world preset of the campaign.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum PresetArg {
    Tiny,
    District,
}

/// The simulator's sensor realism.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum RealismArg {
    Ideal,
    Default,
    Harsh,
}

/// The flags of `plumbline-eval registration` (see the module docs).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// World preset.
    #[arg(long, value_enum, default_value = "tiny")]
    pub preset: PresetArg,
    /// Route length, metres.
    #[arg(long, default_value_t = 400.0)]
    pub length: f64,
    /// Distance between panoramas, metres.
    #[arg(long, default_value_t = 5.0)]
    pub spacing: f64,
    /// Panorama width, pixels.
    #[arg(long, default_value_t = 1024)]
    pub width: u32,
    /// Seed of the simulated campaign.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// GNSS profiles, comma-separated: open, urban, canyon, mixed (unknown names are skipped).
    #[arg(long, default_value = "open,urban,canyon")]
    pub profiles: String,
    /// Sensor realism the campaign is rendered through.
    #[arg(long, value_enum, default_value = "ideal")]
    pub realism: RealismArg,
    /// Also run with each nuisance switched off in turn; FILTER (comma-separated words) keeps only the rows
    /// whose names contain one of them.
    #[arg(long, value_name = "FILTER", num_args = 0..=1, default_missing_value = "")]
    pub nuisances: Option<String>,
    /// Ortho-project on the level plane even where the world has relief (no terrain model).
    #[arg(long)]
    pub level_plane: bool,
    /// Print every pair's image-derived motion error.
    #[arg(long)]
    pub motion_pairs: bool,
    /// List every panorama with markings that was not matched, with each aerial image's fate.
    #[arg(long)]
    pub failed: bool,
    /// List every checked panorama's aerial offset against the truth.
    #[arg(long)]
    pub offsets: bool,
    /// Aerial matching (§3.8): smallest accepted NCC coefficient.
    #[arg(long)]
    pub min_ncc: Option<f64>,
    /// Aerial matching (§3.8): half-size of the NCC/LSM template, aerial pixels.
    #[arg(long)]
    pub template_half: Option<usize>,
    /// Aerial matching (§3.8): NCC search radius around the transferred point, aerial pixels.
    #[arg(long)]
    pub search_radius: Option<usize>,
    /// Without a plausible initial transformation, search every corner over the plausibility bound around
    /// its DG transfer.
    #[arg(long, value_name = "true|false")]
    pub dg_search: Option<bool>,
    /// Aerial matching (§3.8): smallest Förstner roundness of an output point (0: edge points too).
    #[arg(long)]
    pub min_roundness: Option<f64>,
    /// The cross-panorama check (§3.9) on or off.
    #[arg(long, value_name = "true|false")]
    pub crosscheck: Option<bool>,
    /// Initial transformation (§3.7): plausible candidates the corner matching chooses between.
    #[arg(long)]
    pub initial_candidates: Option<usize>,
    /// Initial transformation (§3.7): fewest KAZE inliers.
    #[arg(long)]
    pub min_initial_inliers: Option<usize>,
    /// Initial transformation (§3.7): pool the KAZE matches of all windows of a patch.
    #[arg(long, value_name = "true|false")]
    pub pool_windows: Option<bool>,
    /// Fewest triangulated MM points for an aerial registration.
    #[arg(long)]
    pub min_mm_points: Option<usize>,
    /// Largest height of an MM point above or below the ortho-projection's ground, metres
    #[arg(long)]
    pub max_height_offset: Option<f64>,
}

/// The default pipeline with the experiment overrides of `args`.
fn config(args: &Args) -> PipelineConfig {
    let mut c = PipelineConfig::default();
    let a = &mut c.aerial;
    a.min_ncc = args.min_ncc.unwrap_or(a.min_ncc);
    a.template_half = args.template_half.unwrap_or(a.template_half);
    a.search_radius = args.search_radius.unwrap_or(a.search_radius);
    a.dg_search = args.dg_search.unwrap_or(a.dg_search);
    a.min_roundness = args.min_roundness.unwrap_or(a.min_roundness);
    a.initial_candidates = args.initial_candidates.unwrap_or(a.initial_candidates);
    a.min_initial_inliers = args.min_initial_inliers.unwrap_or(a.min_initial_inliers);
    a.pool_windows = args.pool_windows.unwrap_or(a.pool_windows);
    c.cross_check.enabled = args.crosscheck.unwrap_or(c.cross_check.enabled);
    c.min_mm_points = args.min_mm_points.unwrap_or(c.min_mm_points);
    c.mm.max_height_offset = args.max_height_offset.unwrap_or(c.mm.max_height_offset);
    c
}

fn profile(name: &str) -> Option<Profile> {
    match name {
        "open" => Some(Profile::Open),
        "urban" => Some(Profile::Urban),
        "canyon" => Some(Profile::Canyon),
        "mixed" => Some(Profile::Mixed),
        _ => None,
    }
}

/// One profile's numbers.
struct Row {
    name: String,
    images: usize,
    matched: usize,
    kaze_pairs: usize,
    correspondences: usize,
    correct: usize,
    median_error: f64,
    dg_error_median: f64,
    reasons: BTreeMap<String, usize>,
    timings: StageTimings,
    build_s: f64,
    split: Split,
    /// Correspondences and correct ones of the panoramas with markings.
    marked_correspondences: (usize, usize),
    /// Image-derived motions scored against the truth.
    motions: Vec<MotionCheck>,
    /// Per motion: flagged by the consistency check.
    flagged: Vec<bool>,
    /// Per aerial point: panorama id, height error against the truth, reported σ_H (m).
    heights: Vec<heights::HeightError>,
    /// Where true correspondences were lost, by panorama fate (panoramas with markings).
    losses: BTreeMap<String, losses::Losses>,
    /// The aerial points that are not correct, described.
    wrong: Vec<String>,
    /// The same points explained: truth, MM height, every frame's search (module `diagnosis::wrong`).
    explained: Vec<String>,
    /// The panoramas with markings that were not matched, described (`--failed`).
    failed: Vec<String>,
    /// The cross-panorama check scored against the truth.
    crosscheck: diagnosis::crosscheck::Scored,
}

/// One row per profile in `profiles` (comma-separated; unknown names skipped) of `base`'s campaign. The
/// panoramas are rendered once: the next profile only replaces the DG poses (`Campaign::reprofile`).
fn rows(profiles: &str, base: &Spec, args: &Args) -> Vec<Row> {
    let mut previous: Option<Campaign> = None;
    let mut rows = Vec::new();
    for (name, profile) in profiles.split(',').filter_map(|name| profile(name.trim()).map(|p| (name.trim(), p))) {
        let spec = Spec { profile, ..*base };
        let t0 = Instant::now();
        let mut campaign = match previous.take() {
            Some(mut campaign) => {
                if campaign.reprofile(&spec) {
                    campaign
                } else {
                    Campaign::build(&spec)
                }
            }
            None => Campaign::build(&spec),
        };
        if args.level_plane {
            // Ortho-project on the level plane even where the world has relief (what a campaign without a
            // terrain model gets).
            campaign.rig.terrain = None;
        }
        let row = run(name, &campaign, t0.elapsed().as_secs_f64(), args);
        eprintln!("{name}: {} of {} images matched", row.matched, row.images);
        rows.push(row);
        previous = Some(campaign);
    }
    rows
}

/// The row of one profile's `campaign`, built (or re-profiled) in `build_s` seconds.
fn run(name: &str, campaign: &Campaign, build_s: f64, args: &Args) -> Row {
    let config = config(args);
    let t1 = Instant::now();
    let prepared = prepare_panoramas(&campaign.panoramas, &campaign.rig, &config.mm);
    let mut run = register_tile(TileId { col: 0, row: 0 }, &prepared, &campaign.rig, &campaign.reference, &config);
    // The wall time of step 1 and the features (prepared first) and of the pairs.
    run.timings.total = t1.elapsed();
    let result = run.result.into_latest();
    let half = PipelineConfig::default().mm.half_extent;
    let ids = campaign.truth.iter().map(|(id, _)| id.clone());
    let paint: BTreeMap<String, f64> = ids.clone().zip(campaign.paint_areas(half)).collect();
    let dg_error: BTreeMap<String, f64> = ids.zip(campaign.dg_error.iter().copied()).collect();
    let split = Split::of(&result, &paint, &dg_error);
    let errors = campaign.aerial_errors(&result);
    let motions = campaign.motion_checks(&result);
    let image_motions: Vec<_> = result.images.iter().filter_map(|d| d.motion).collect();
    let flagged = motion::flags(&campaign.panoramas, &image_motions);
    let horizontal: Vec<f64> = errors.iter().map(|(e, _)| e[0].hypot(e[1])).collect();
    let marked = |id: &str| paint.get(id).is_some_and(|&a| a >= MARKINGS_MIN_M2);
    let losses = losses::losses(campaign, &result, &run.traces, &marked);
    let explained = diagnosis::wrong::explain(campaign, &result, &run.traces, 2.0 * AERIAL_GSD);
    let mut wrong = losses::wrong_points(campaign, &result, AERIAL_GSD);
    wrong.push(format!("all points' σ_h q10/50/90/99 {:.3?} m", losses::sigma_quantiles(&result)));
    wrong.push(diagnosis::wrong::ambiguity(campaign, &result, &run.traces, 2.0));
    let failed = losses::failed_panoramas(campaign, &result, &marked);
    let crosscheck = diagnosis::crosscheck::score(campaign, &result, args.offsets);
    let marked_errors: Vec<f64> = result
        .ties
        .iter()
        .filter(|t| t.aerial.is_some())
        .zip(&horizontal)
        .filter(|(t, _)| t.id.0.split(':').next().is_some_and(marked))
        .map(|(_, e)| *e)
        .collect();
    let heights = result
        .ties
        .iter()
        .filter(|t| t.aerial.is_some())
        .zip(&errors)
        .map(|(t, (e, s))| (t.id.0.split(':').next().unwrap_or("").to_owned(), e[2], s[2]))
        .collect();
    let marked_correspondences =
        (marked_errors.len(), marked_errors.iter().filter(|&&e| e <= 2.0 * AERIAL_GSD).count());
    let correct = horizontal.iter().filter(|&&e| e <= 2.0 * AERIAL_GSD).count();
    let mut horizontal = horizontal;
    let median_error = median(&mut horizontal).unwrap_or(f64::NAN);
    let dg_error_median = median(&mut campaign.dg_error.clone()).unwrap_or(f64::NAN);
    let kaze_pairs = result.images.iter().filter(|d| matches!(d.transform, Some(TransformSource::Kaze { .. }))).count();
    Row {
        name: name.to_owned(),
        images: result.summary.images,
        matched: result.summary.images_matched,
        kaze_pairs,
        correspondences: horizontal.len(),
        correct,
        median_error,
        dg_error_median,
        reasons: result.summary.discarded,
        timings: run.timings,
        build_s,
        split,
        marked_correspondences,
        motions,
        flagged,
        heights,
        losses,
        wrong,
        explained,
        failed,
        crosscheck,
    }
}

fn print_tables(rows: &[Row], args: &Args) {
    println!(
        "\n| profile | images | images matched | correspondences | correct (≤ 2 px = {:.2} m) | median horiz. error (m) | median DG error (m) | KAZE pairs |",
        2.0 * AERIAL_GSD
    );
    println!("|---|---|---|---|---|---|---|---|");
    for r in rows {
        let share = if r.correspondences > 0 { 100.0 * r.correct as f64 / r.correspondences as f64 } else { f64::NAN };
        println!(
            "| {} | {} | {} ({:.0} %) | {} | {:.1} % | {:.3} | {:.3} | {} |",
            r.name,
            r.images,
            r.matched,
            100.0 * r.matched as f64 / r.images.max(1) as f64,
            r.correspondences,
            share,
            r.median_error,
            r.dg_error_median,
            r.kaze_pairs
        );
    }
    print_split(rows);
    let height_rows: Vec<_> = rows.iter().map(|r| (r.name.as_str(), r.heights.as_slice())).collect();
    heights::print_table(&height_rows);
    let motion_rows: Vec<_> =
        rows.iter().map(|r| (r.name.as_str(), r.images, r.motions.as_slice(), r.flagged.as_slice())).collect();
    motion::print_table(&motion_rows);
    if args.motion_pairs {
        rows.iter().for_each(|r| motion::print_pairs(&r.name, &r.motions));
    }
    println!("\n| profile | why images failed (count) |\n|---|---|");
    for r in rows {
        let reasons: Vec<String> = r.reasons.iter().map(|(k, v)| format!("{k}: {v}")).collect();
        println!("| {} | {} |", r.name, reasons.join(", "));
    }
    print_crosscheck(rows);
    print_causes(rows);
    let loss_rows: Vec<_> = rows.iter().map(|r| (r.name.as_str(), r.losses.clone())).collect();
    losses::print(&loss_rows);
    println!("\nAerial points off by more than 2 aerial pixels: tie, horizontal / height error / σ_H, ×frames\n");
    for r in rows {
        println!("- {}: {}", r.name, r.wrong.join("; "));
    }
    println!("\nThe same points explained: what the MM ray truly hits, the MM rays' height, each frame's search\n");
    for r in rows {
        r.explained.iter().for_each(|line| println!("- {}: {line}", r.name));
    }
    if args.failed {
        println!("\nPanoramas WITH markings not matched: id, fate, true DG error E/N, reported σ; per aerial image:");
        println!("rejection, KAZE inliers, correlation NCC, offset\n");
        rows.iter().for_each(|r| r.failed.iter().for_each(|f| println!("- {}: {f}", r.name)));
    }
    println!(
        "\n| profile | ortho-projection | features | matching | triangulation | aerial | elapsed | render (not pipeline) |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for r in rows {
        let per = |d: std::time::Duration| 1e3 * d.as_secs_f64() / r.images.max(1) as f64;
        let t = &r.timings;
        println!(
            "| {} | {:.0} ms | {:.0} ms | {:.0} ms | {:.2} ms | {:.0} ms | {:.0} ms | {:.1} s total |",
            r.name,
            per(t.ortho),
            per(t.features),
            per(t.matching),
            per(t.triangulation),
            per(t.aerial),
            per(t.total),
            r.build_s
        );
    }
    println!("\nStage times are thread-time per panorama (stages run in parallel on rayon's pool); `elapsed` is the");
    println!("wall time of `prepare_panoramas` + `register_tile` divided by the panoramas; the render is the first");
    println!("profile's (the others re-use its panoramas with their own DG poses: seconds),");
    println!("on {} threads.", rayon::current_num_threads());
}

fn reasons(map: &BTreeMap<String, usize>) -> String {
    map.iter().map(|(k, v)| format!("{k}: {v}")).collect::<Vec<_>>().join(", ")
}

fn print_split(rows: &[Row]) {
    println!("\nBy ground truth: a panorama has markings when ≥ {MARKINGS_MIN_M2} m² of road paint visible at both");
    println!("epochs lies in its ortho patch (lane lines, stop lines, zebra crossings, arrows).");
    println!("\n| profile | group | images | images matched | correspondences | correct | why images failed |");
    println!("|---|---|---|---|---|---|---|");
    for r in rows {
        let (n, ok) = r.marked_correspondences;
        let share =
            |c: usize, n: usize| if n > 0 { format!("{:.1} %", 100.0 * c as f64 / n as f64) } else { "–".into() };
        let (w, wo) = (&r.split.with, &r.split.without);
        let (n_wo, ok_wo) = (r.correspondences - n, r.correct - ok);
        for (name, g, n, ok) in [("markings", w, n, ok), ("no markings", wo, n_wo, ok_wo)] {
            let matched = format!("{} ({})", g.matched, share(g.matched, g.images));
            println!(
                "| {} | {name} | {} | {matched} | {n} | {} | {} |",
                r.name,
                g.images,
                share(ok, n),
                reasons(&g.reasons)
            );
        }
    }
}

fn print_crosscheck(rows: &[Row]) {
    println!(
        "\nCross-panorama check (Jende et al. 2017 §3.9) against the truth: a registration is truly wrong when its"
    );
    println!("offset misses minus the true DG error by more than 2 aerial pixels ({:.2} m).", 2.0 * AERIAL_GSD);
    println!(
        "\n| profile | offsets checked | flagged | flagged truly wrong / right | kept truly wrong | kept unverified | motions contradicted: true error (m) | kept: max residual / bound, max residual (m) |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for r in rows {
        let c = &r.crosscheck;
        let right = c.flagged - c.flagged_wrong;
        let motions: Vec<String> = c.contradicted.iter().map(|(id, e)| format!("{id} {e:.2}")).collect();
        println!(
            "| {} | {} | {} | {} / {right} | {} | {} | {} | {:.2}, {:.3} |",
            r.name,
            c.checked,
            c.flagged,
            c.flagged_wrong,
            c.kept_wrong,
            c.unverified,
            motions.join(", "),
            c.margin.0,
            c.margin.1
        );
    }
    println!();
    rows.iter().for_each(|r| r.crosscheck.lines.iter().for_each(|l| println!("- {}: {l}", r.name)));
}

fn print_causes(rows: &[Row]) {
    println!("\nPanoramas WITH markings discarded as too_few_plausible: each overlapping aerial image's fate in §3.7");
    println!("((a) KAZE found no transform; (b) the transform's offset equals the true DG error within 0.25 m, i.e.");
    println!("it was right and the bound 3σ + 0.5 m too tight; (c) a wrong transform correctly rejected).");
    println!("\n| profile | panoramas | aerial images by cause | (b): offset / bound / true DG error, m |");
    println!("|---|---|---|---|");
    for r in rows {
        let c = &r.split.causes;
        let tight: Vec<String> = c.too_tight.iter().take(8).map(|(o, b, e)| format!("{o:.2}/{b:.2}/{e:.2}")).collect();
        let more = if c.too_tight.len() > 8 { format!(" … ({} in all)", c.too_tight.len()) } else { String::new() };
        let images: BTreeMap<String, usize> = c.images.iter().map(|(k, v)| ((*k).to_owned(), *v)).collect();
        println!("| {} | {} | {} | {}{more} |", r.name, c.panoramas, reasons(&images), tight.join(", "));
    }
    println!("\n(a) in detail: KAZE matches / best inliers / whole-patch NCC of the correlation fallback\n");
    for r in rows {
        let mut none = r.split.causes.none_found.clone();
        none.sort_by_key(|n| std::cmp::Reverse(n.1));
        let items: Vec<String> = none
            .iter()
            .take(24)
            .map(|(m, i, ncc)| format!("{m}/{i}/{}", ncc.map_or("–".into(), |n| format!("{n:.2}"))))
            .collect();
        println!("- {}: {}", r.name, items.join(", "));
    }
    println!("\nPanoramas WITH markings discarded as too_few_correspondences: MM points triangulated → per aerial");
    println!(
        "image that passed §3.7, corner candidates / NCC matches / correspondences kept (10 needed in all images\ntogether, from at least 2 images)\n"
    );
    for r in rows {
        let items: Vec<String> = r
            .split
            .causes
            .starved
            .iter()
            .map(|(n, imgs)| {
                let i: Vec<String> = imgs.iter().map(|(c, m, k)| format!("{c}/{m}/{k}")).collect();
                format!("{n} → [{}]", i.join(" "))
            })
            .collect();
        println!("- {}: {}", r.name, items.join("; "));
    }
}

/// The realism of `--realism`.
fn realism(level: RealismArg) -> Realism {
    Realism::of(match level {
        RealismArg::Default => RealismLevel::Default,
        RealismArg::Harsh => RealismLevel::Harsh,
        RealismArg::Ideal => RealismLevel::Ideal,
    })
}

/// `base` with one nuisance switched off, by name.
fn nuisances(base: Realism) -> Vec<(&'static str, Realism)> {
    let street = |r: Radiometry| Realism { street: r, ..base };
    let rig = |r: Rig| Realism { rig: r, ..base };
    let ideal = Radiometry::IDEAL;
    vec![
        ("all", base),
        ("no seams (one centre, one exposure)", rig(Rig { radius_m: 0.0, exposure_step: 0.0, ..base.rig })),
        ("no parallax at the seams (one centre)", rig(Rig { radius_m: 0.0, ..base.rig })),
        ("no exposure steps (one exposure)", rig(Rig { exposure_step: 0.0, ..base.rig })),
        ("no rolling shutter", rig(Rig { readout_s: 0.0, ..base.rig })),
        ("no motion blur", rig(Rig { exposure_s: 0.0, ..base.rig })),
        (
            "aerial: crowns not spread over the road",
            Realism { world: EpochChanges { crown_spread: 1.0, ..base.world }, ..base },
        ),
        ("no pedestrians", Realism { world: EpochChanges { pedestrians_per_100m: 0.0, ..base.world }, ..base }),
        ("flat ground (no hills, cross-fall or kerbs)", Realism { relief: Relief::FLAT, ..base }),
        ("street: no white balance error", street(Radiometry { white_balance: [1.0; 3], ..base.street })),
        ("street: no S-curve", street(Radiometry { s_curve: 0.0, ..base.street })),
        ("street: no vignetting", street(Radiometry { vignetting: 0.0, ..base.street })),
        ("street: no noise", street(Radiometry { noise: 0.0, ..base.street })),
        (
            "aerial: ideal radiometry",
            Realism { aerial: Radiometry { jpeg_quality: base.aerial.jpeg_quality, ..ideal }, ..base },
        ),
        (
            "JPEG quality 90 both",
            Realism {
                street: Radiometry { jpeg_quality: 90, ..base.street },
                aerial: Radiometry { jpeg_quality: 90, ..base.aerial },
                ..base
            },
        ),
    ]
}

/// One row per nuisance switched off: images with markings matched and their correct share, all images.
fn print_nuisances(variants: &[(&str, Vec<Row>)]) {
    println!(
        "
Each nuisance switched off in turn (`--nuisances`)
"
    );
    println!(
        "| switched off | profile | with markings matched | their correct share | all matched | correct share | median horiz. error (m) |"
    );
    println!("|---|---|---|---|---|---|---|");
    let share = |c: usize, n: usize| if n > 0 { format!("{:.1} %", 100.0 * c as f64 / n as f64) } else { "–".into() };
    for (name, rows) in variants {
        for r in rows {
            let (n, ok) = r.marked_correspondences;
            let w = &r.split.with;
            println!(
                "| {name} | {} | {} of {} ({}) | {} | {} of {} | {} | {:.3} |",
                r.name,
                w.matched,
                w.images,
                share(w.matched, w.images),
                share(ok, n),
                r.matched,
                r.images,
                share(r.correct, r.correspondences),
                r.median_error
            );
        }
    }
}

/// `plumbline-eval registration`: every table of the module docs.
pub fn main(args: &Args) {
    let preset = match args.preset {
        PresetArg::District => world::Preset::District,
        PresetArg::Tiny => world::Preset::Tiny,
    };
    let profiles = args.profiles.as_str();
    let base = Spec {
        preset,
        seed: args.seed,
        profile: Profile::Open,
        length: args.length,
        spacing: args.spacing,
        width: args.width,
        window: None,
        realism: realism(args.realism),
    };
    println!(
        "registration bench: preset {preset:?}, seed {}, route {} m, panoramas every {} m at {} px, realism {:?}",
        base.seed, base.length, base.spacing, base.width, base.realism.level
    );
    let table = rows(profiles, &base, args);
    print_tables(&table, args);
    if let Some(only) = &args.nuisances {
        // No FILTER (or `1`, as before): every nuisance; otherwise comma-separated words, a row runs when its
        // name has one.
        let wanted = |name: &str| {
            only.is_empty() || only == "1" || only.split(',').any(|w| name.contains(w.trim())) || name == "all"
        };
        let mut variants = Vec::new();
        for (name, realism) in nuisances(base.realism).into_iter().filter(|(name, _)| wanted(name)) {
            let rows = rows(profiles, &Spec { realism, ..base }, args);
            eprintln!("{name}: done");
            variants.push((name, rows));
        }
        print_nuisances(&variants);
    }
}
