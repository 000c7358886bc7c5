//! Road-marking extraction against the simulator's truth with the trajectory taken out: every panorama of
//! a synthetic drive is ortho-projected with its *true* pose (the worker's step 1 and stroke extraction,
//! `prepare_panorama`), the strokes are linked into pieces by the same assembly the adjuster runs, and the
//! pieces are scored against the world's markings within reach of the drive. What is lost here is lost by
//! the extraction and the assembly alone; `plumbline demo` adds the trajectory's error on top.
//!
//! The table splits solid lines into the parking strips' edge lines (beside parked cars) and the others.
//! `--missed` lists every marking found on less than half its length; `--dump DIR` writes PNGs of ortho
//! patches (grey: the patch; dark blue: cells that saw no ground; red: strokes; green: the truth's centre
//! lines) for the panoramas named by `--panoramas`, or else for the panoramas nearest to the longest missed
//! markings.
//!
//! `cargo run --release -p plumbline-eval -- lines [--preset district] [--length 300] [--width 4096]
//! [--realism harsh] [--missed] [--dump DIR [--panoramas pano00012,pano00013]]`.

use std::collections::BTreeMap;
use std::time::Instant;

use plumbline_fixtures::registration::{Campaign, Profile, Spec};
use plumbline_geo::Attitude;
use plumbline_lines::{AssembleConfig, ElementScore, EvaluateConfig, Observed, Piece, TruthElement, within_reach};
use plumbline_registration::mm::{MmConfig, Panorama};
use plumbline_registration::pipeline::prepare_panorama;
use plumbline_synth::render::{Realism, RealismLevel};
use plumbline_synth::texture::{markings_csv, road_markings};
use plumbline_synth::world::{self, StreetClass, World};
use rayon::prelude::*;

use crate::registration::{PresetArg, RealismArg};

/// Markings farther than this from every panorama are out of reach (as `lines compare` and `demo`), metres.
const REACH_M: f64 = 10.0;

/// Flags of `plumbline-eval lines`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// World preset.
    #[arg(long, value_enum, default_value = "district")]
    preset: PresetArg,
    /// Route length, metres.
    #[arg(long, default_value_t = 300.0)]
    length: f64,
    /// Distance between panoramas, metres.
    #[arg(long, default_value_t = 5.0)]
    spacing: f64,
    /// Panorama width, pixels (default: 1024 for tiny, 4096 for district).
    #[arg(long)]
    width: Option<u32>,
    /// Seed of the world and the drive.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// The simulator's sensor realism.
    #[arg(long, value_enum, default_value = "ideal")]
    realism: RealismArg,
    /// List every marking found on less than half its length.
    #[arg(long)]
    missed: bool,
    /// Write PNGs of ortho patches with their strokes and the truth into this directory.
    #[arg(long, value_name = "DIR")]
    dump: Option<String>,
    /// Override the extraction's widest freed stroke, metres (0: components rejected whole are not freed of
    /// wider bright areas; see `ExtractConfig::max_freed_width_m`).
    #[arg(long)]
    max_freed_width: Option<f64>,
    /// Panorama ids to dump, comma-separated (default: those nearest to the six longest missed markings).
    #[arg(long, value_delimiter = ',')]
    panoramas: Vec<String>,
}

/// Run the evaluation.
pub fn main(args: &Args) {
    let (preset, default_width) = match args.preset {
        PresetArg::District => (world::Preset::District, 4096),
        PresetArg::Tiny => (world::Preset::Tiny, 1024),
    };
    let level = match args.realism {
        RealismArg::Ideal => RealismLevel::Ideal,
        RealismArg::Default => RealismLevel::Default,
        RealismArg::Harsh => RealismLevel::Harsh,
    };
    let spec = Spec {
        preset,
        seed: args.seed,
        profile: Profile::Open,
        length: args.length,
        spacing: args.spacing,
        width: args.width.unwrap_or(default_width),
        window: None,
        realism: Realism::of(level),
    };
    let started = Instant::now();
    let campaign = Campaign::build(&spec);
    let built = started.elapsed().as_secs_f64();
    let mut config = MmConfig::default();
    if let (Some(width), Some(lines)) = (args.max_freed_width, config.lines.as_mut()) {
        lines.max_freed_width_m = width;
    }
    let extracted = Instant::now();
    // The worker's step 1 and extraction, with the true pose in place of the DG pose.
    let prepared: Vec<_> = campaign
        .panoramas
        .par_iter()
        .zip(&campaign.truth)
        .map(|(pano, (_, truth))| {
            let pano = Panorama { pose: *truth, ..pano.clone() };
            prepare_panorama(&pano, true, &campaign.rig, &config)
        })
        .collect();
    let extract_s = extracted.elapsed().as_secs_f64();
    let mut observed = Vec::new();
    let mut centres = Vec::new();
    let mut without = 0;
    for (k, p) in prepared.iter().enumerate() {
        let body = p.pose().translation;
        centres.push([body.x(), body.y()]);
        without += usize::from(p.strokes().is_empty());
        let heading = Attitude::from_rotation(&p.pose().rotation).heading;
        observed.extend(p.strokes().iter().map(|s| Observed {
            points: s.points.clone(),
            width_m: s.width_m,
            sigma_m: s.sigma_m,
            common_sigma_m: 0.0,
            open: s.open,
            panorama: k,
            heading,
        }));
    }
    let assembly = plumbline_lines::assemble(&observed, &AssembleConfig::default());
    let csv = markings_csv(&road_markings(&campaign.world));
    let csv = String::from_utf8(csv).expect("the simulator writes UTF-8");
    let truth = plumbline_lines::parse_markings_csv(&csv).expect("the simulator's markings parse");
    let truth = within_reach(&truth, &centres, REACH_M);
    let evaluate = EvaluateConfig::default();
    let score = plumbline_lines::evaluate(&assembly.pieces, &truth, &evaluate);
    let markings = plumbline_lines::per_element(&assembly.pieces, &truth, &evaluate);

    println!(
        "road-marking extraction with the true poses: preset {preset:?}, seed {}, route {} m, panoramas every {} m \
         at {} px, realism {level:?}; freed strokes up to {} m wide",
        spec.seed,
        spec.length,
        spec.spacing,
        spec.width,
        config.lines.map_or(0.0, |l| l.max_freed_width_m)
    );
    println!(
        "{} panoramas ({without} without strokes), {} strokes, {} pieces; rendered in {built:.0} s, step 1 and \
         extraction {extract_s:.0} s wall",
        prepared.len(),
        observed.len(),
        assembly.pieces.len()
    );
    println!();
    println!("| markings | length within reach (m) | recovered | found (≥ half) |");
    println!("|---|---|---|---|");
    let mut classes: BTreeMap<String, (f64, f64, usize, usize)> = BTreeMap::new();
    for m in &markings {
        let entry = classes.entry(class_of(&campaign.world, m)).or_default();
        entry.0 += m.length_m;
        entry.1 += m.recovered_length_m;
        entry.2 += 1;
        entry.3 += usize::from(m.is_found());
    }
    for (name, (length, recovered, count, found)) in &classes {
        println!("| {name} | {length:.0} | {} | {found} of {count} |", percent(*recovered, *length));
    }
    println!(
        "| all | {:.0} | {} | {} of {} |",
        score.truth_length_m,
        percent(score.recovered_length_m, score.truth_length_m),
        markings.iter().filter(|m| m.is_found()).count(),
        markings.len()
    );
    println!();
    println!(
        "extracted {:.0} m, {} correct (within {} m of a marking); {} of {} vertices within {} m",
        score.extracted_length_m,
        percent(score.correct_length_m, score.extracted_length_m),
        evaluate.match_m,
        percent(score.vertices_within as f64, score.vertices as f64),
        score.vertices,
        evaluate.accuracy_m
    );
    // Strokes off every marking, per panorama: each stroke's length the evaluation finds not correct.
    let mut off: Vec<(f64, usize, String)> = prepared
        .iter()
        .map(|p| {
            let pieces: Vec<Piece> = p
                .strokes()
                .iter()
                .map(|s| Piece {
                    vertices: s.points.clone(),
                    sigma_m: vec![s.sigma_m; s.points.len()],
                    width_m: s.width_m,
                    observations: 1,
                    panoramas: 1,
                    closed: s.open.map(|open| !open),
                })
                .collect();
            let (length, count) = pieces
                .iter()
                .map(|piece| plumbline_lines::evaluate(std::slice::from_ref(piece), &truth, &evaluate))
                .map(|one| one.extracted_length_m - one.correct_length_m)
                .filter(|wrong| *wrong > 0.0)
                .fold((0.0, 0), |(l, n), wrong| (l + wrong, n + 1));
            (length, count, p.id().to_string())
        })
        .filter(|(length, _, _)| *length > 0.0)
        .collect();
    off.sort_by(|a, b| b.0.total_cmp(&a.0));
    println!(
        "strokes off every marking: {:.0} m in {} panoramas; most in {}",
        off.iter().map(|o| o.0).sum::<f64>(),
        off.len(),
        off.iter().take(6).map(|o| format!("{} ({:.1} m, {})", o.2, o.0, o.1)).collect::<Vec<_>>().join(", ")
    );
    let ids: Vec<String> = prepared.iter().map(|p| p.id().to_string()).collect();
    let mut missed: Vec<&ElementScore> = markings.iter().filter(|m| !m.is_found()).collect();
    missed.sort_by(|a, b| b.length_m.total_cmp(&a.length_m));
    if args.missed {
        println!();
        println!("missed (found on less than half their length), longest first:");
        for m in &missed {
            let nearest =
                truth.iter().find(|t| t.id == m.id).map_or(String::new(), |t| nearest_panorama(&ids, &centres, t));
            println!(
                "- {} ({}, {}): {:.1} of {:.1} m, nearest {nearest}",
                m.id,
                m.kind,
                class_of(&campaign.world, m),
                m.recovered_length_m,
                m.length_m
            );
        }
    }
    if let Some(dir) = &args.dump {
        let wanted: Vec<String> = if args.panoramas.is_empty() {
            let mut v: Vec<String> = missed
                .iter()
                .filter_map(|m| truth.iter().find(|t| t.id == m.id))
                .map(|t| nearest_panorama(&ids, &centres, t))
                .collect();
            v.dedup();
            v.truncate(6);
            v
        } else {
            args.panoramas.clone()
        };
        std::fs::create_dir_all(dir).expect("dump directory");
        for p in prepared.iter().filter(|p| wanted.iter().any(|w| w == p.id())) {
            let Some(patch) = p.patch() else { continue };
            let path = format!("{dir}/{}.png", p.id());
            dump(&path, patch, p.strokes(), &truth);
            println!("wrote {path}");
        }
    }
}

/// `part / whole` as a percentage, or a dash when `whole` is zero.
fn percent(part: f64, whole: f64) -> String {
    if whole > 0.0 { format!("{:.1} %", 100.0 * part / whole) } else { "–".into() }
}

/// The marking's class for the table: its kind, solid lines split into the parking strips' edge lines and
/// the others (read from the simulator's id `s{street}.l{line}` and the street's line order: centre line(s),
/// lane lines, then the two parking edges).
fn class_of(world: &World, m: &ElementScore) -> String {
    if m.kind != "solid" {
        return m.kind.to_string();
    }
    let parse = || -> Option<(u32, u32)> {
        let mut parts = m.id.strip_prefix('s')?.split('.');
        let key = parts.next()?.parse().ok()?;
        let line = parts.next()?.strip_prefix('l')?.parse().ok()?;
        Some((key, line))
    };
    let Some((key, line)) = parse() else { return "solid".into() };
    let Some(street) = world.streets.iter().find(|s| s.key == key) else { return "solid".into() };
    let centre = if street.class == StreetClass::Arterial { 2 } else { 1 };
    let lines = centre + 2 * street.lanes.saturating_sub(1);
    if street.parking > 0.0 && line >= lines { "solid: parking edge".into() } else { "solid: other".into() }
}

/// The id of the panorama nearest to the middle vertex of `t`.
fn nearest_panorama(ids: &[String], centres: &[[f64; 2]], t: &TruthElement) -> String {
    let m = t.points[t.points.len() / 2];
    let d = |c: &[f64; 2]| (c[0] - m[0]).hypot(c[1] - m[1]);
    ids.iter().zip(centres).min_by(|a, b| d(a.1).total_cmp(&d(b.1))).map_or(String::new(), |(id, _)| id.clone())
}

/// Write `patch` as an RGB PNG with `strokes` (red) and the truth's centre lines (green) drawn on it.
fn dump(
    path: &str,
    patch: &plumbline_registration::mm::OrthoPatch,
    strokes: &[plumbline_lines::Stroke],
    truth: &[TruthElement],
) {
    let (w, h) = (patch.image.width(), patch.image.height());
    // Grey values stretched between the 1st and the 99th percentile of the valid cells.
    let mut seen: Vec<f32> =
        patch.image.data().iter().zip(patch.valid.data()).filter(|(_, v)| **v).map(|(g, _)| *g).collect();
    seen.sort_by(f32::total_cmp);
    let at = |q: f64| seen.get(((seen.len() as f64 - 1.0) * q) as usize).copied().unwrap_or(0.0);
    let (lo, hi) = (at(0.01), at(0.99).max(at(0.01) + 1e-3));
    let mut rgb = image::RgbImage::new(w as u32, h as u32);
    for r in 0..h {
        for c in 0..w {
            let px = if patch.valid.data()[r * w + c] {
                let g = ((patch.image.get(c, r) - lo) / (hi - lo) * 255.0).clamp(0.0, 255.0) as u8;
                [g, g, g]
            } else {
                [0, 0, 90]
            };
            rgb.put_pixel(c as u32, r as u32, image::Rgb(px));
        }
    }
    let mut draw = |points: &[[f64; 2]], colour: [u8; 3]| {
        for pair in points.windows(2) {
            let (a, b) = (patch.grid.to_pixel(pair[0][0], pair[0][1]), patch.grid.to_pixel(pair[1][0], pair[1][1]));
            let steps = ((b[0] - a[0]).hypot(b[1] - a[1]) * 2.0).ceil().max(1.0) as usize;
            for k in 0..=steps {
                let t = k as f64 / steps as f64;
                let (u, v) = (a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t);
                if u >= 0.0 && v >= 0.0 && (u as usize) < w && (v as usize) < h {
                    rgb.put_pixel(u as u32, v as u32, image::Rgb(colour));
                }
            }
        }
    };
    for t in truth {
        draw(&t.points, [0, 200, 0]);
    }
    for s in strokes {
        draw(&s.points, [230, 0, 0]);
    }
    rgb.save(path).expect("PNG written");
}
