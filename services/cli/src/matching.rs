//! `plumbline match`: register two images with KAZE or AKAZE features and RANSAC, print the transform (A pixels →
//! B pixels), the inlier count and the residuals as JSON, and optionally draw the matches side by side.
//!
//! Images are decoded within a pixel budget (`--max-pixels`, checked on the header before any pixel is
//! decoded; invalid input otherwise). A consensus too small to be a solution ([`min_inliers`],
//! `--min-inlier-ratio`) is a failure: no matrix is printed.

use std::process::ExitCode;

use anyhow::Context as _;
use clap::{Args as ClapArgs, ValueEnum};
use plumbline_imaging::GrayImage;
use plumbline_imaging::akaze::{AkazeConfig, Keypoint, akaze, match_descriptors};
use plumbline_imaging::decode::{Bounds, DecodeError, decode_gray};
use plumbline_imaging::kaze::{KazeConfig, kaze, match_surf};
use plumbline_imaging::models::{Correspondence, Model};
use plumbline_imaging::ransac::{RansacConfig, RansacFit, ransac};
use serde_json::json;

use crate::exit::invalid;
use crate::io::Context;

/// Default of `--max-pixels`: 64 Mi px, an 8192 × 8192 image. KAZE keeps ~16 full-resolution f32 levels
/// (4 GiB at this size), so larger images are better cut or downsampled first.
pub const DEFAULT_MAX_PIXELS: u64 = 8_192 * 8_192;

/// Default of `--min-inlier-ratio`: a consensus of fewer than 5 % of the matches is not reported. Chance
/// consensus does not grow with the number of matches the way a real one does (a degenerate homography
/// collapsing image A onto a line of B gathers ≈ 0.6 % of random matches on a 1024² image at 2 px).
pub const DEFAULT_MIN_INLIER_RATIO: f64 = 0.05;

/// Fewest inliers for a fit of `model` to count as a solution: four times its minimal sample, at least 10 —
/// similarity 10, affine 12, homography 16. A minimal sample fits itself exactly (a homography any four
/// pairs), so its own points prove nothing; among random matches a hypothesis gathers chance inliers at
/// rate p ≈ π t² / area of B per match (≈ 2·10⁻⁴ for 2 px on a 256² image), and over RANSAC's up to 10⁴
/// hypotheses with a few hundred matches a handful of extras beyond the sample do occur (observed: a
/// homography "fitted" to 4–5 inliers). Eight or more extras at once stay improbable even if clustered
/// keypoints make p ten times larger; a homography, which can also collapse a region of A onto a few
/// points of B, needs twelve.
pub fn min_inliers(model: Model) -> usize {
    (4 * model.min_samples()).max(10)
}

/// The transform to fit.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum ModelArg {
    /// Rotation, uniform scale, translation.
    Similarity,
    /// General affine.
    Affine,
    /// Plane projective.
    Homography,
}

/// The feature detector.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum DetectorArg {
    /// KAZE with M-SURF descriptors (Jende et al. 2017 §3.3).
    Kaze,
    /// AKAZE with orientation.
    Akaze,
    /// AKAZE without orientation (images already aligned in rotation).
    AkazeUpright,
}

/// Arguments of `match`.
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// Image A (PNG or JPEG), by path or URL.
    pub a: String,
    /// Image B (PNG or JPEG), by path or URL.
    pub b: String,
    /// Transform model mapping A pixels to B pixels.
    #[arg(long, value_enum, default_value = "similarity")]
    pub model: ModelArg,
    /// Feature detector.
    #[arg(long, value_enum, default_value = "akaze")]
    pub detector: DetectorArg,
    /// RANSAC inlier threshold, pixels in B.
    #[arg(long, default_value_t = 2.0)]
    pub threshold: f64,
    /// RANSAC seed (the result is deterministic for a seed).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Write a PNG with both images side by side and the inlier matches drawn.
    #[arg(long, value_name = "PNG")]
    pub matches: Option<String>,
    /// Largest image accepted, in pixels (width × height, read from the header before decoding).
    #[arg(long, value_name = "PIXELS", default_value_t = DEFAULT_MAX_PIXELS)]
    pub max_pixels: u64,
    /// Fewest RANSAC inliers that count as a solution [default: 10 for similarity, 12 for affine, 16 for
    /// homography].
    #[arg(long, value_name = "N")]
    pub min_inliers: Option<usize>,
    /// Smallest share of the matches that must be inliers for a solution.
    #[arg(long, value_name = "SHARE", default_value_t = DEFAULT_MIN_INLIER_RATIO)]
    pub min_inlier_ratio: f64,
}

/// Run `match`.
pub async fn run(ctx: &Context, args: Args) -> anyhow::Result<ExitCode> {
    if !(0.0..=1.0).contains(&args.min_inlier_ratio) {
        return Err(invalid(format!("--min-inlier-ratio {}: must lie in [0, 1]", args.min_inlier_ratio)));
    }
    let budget = Bounds::budget(args.max_pixels);
    let (a, b) = (load(ctx, &args.a, &budget).await?, load(ctx, &args.b, &budget).await?);
    let detector = args.detector;
    let model = match args.model {
        ModelArg::Similarity => Model::Similarity,
        ModelArg::Affine => Model::Affine,
        ModelArg::Homography => Model::Homography,
    };
    let config = RansacConfig { threshold: args.threshold, seed: args.seed, ..RansacConfig::default() };
    let (a, b, fa, fb, pairs, fit) = tokio::task::spawn_blocking(move || -> anyhow::Result<_> {
        let (fa, fb, pairs) = features(&a, &b, detector)?;
        let fit = ransac(model, &pairs, &config)
            .with_context(|| format!("no {} between the images from {} matches", model.name(), pairs.len()))?;
        Ok((a, b, fa, fb, pairs, fit))
    })
    .await??;
    let needed = args.min_inliers.unwrap_or_else(|| min_inliers(model));
    reliable(model, fit.inlier_count(), pairs.len(), needed, args.min_inlier_ratio)?;
    println!("{}", serde_json::to_string_pretty(&report(&args, model, [fa, fb], &pairs, &fit))?);
    if let Some(out) = &args.matches {
        ctx.write(out, draw(&a, &b, &pairs, &fit)?).await?;
    }
    Ok(ExitCode::SUCCESS)
}

/// Whether `inliers` of `matches` are a solution: at least `needed` and at least `ratio` of the matches;
/// otherwise the failure that says why (exit code 1: the inputs are fine, there is no answer in them).
fn reliable(model: Model, inliers: usize, matches: usize, needed: usize, ratio: f64) -> anyhow::Result<()> {
    let share = inliers as f64 / matches.max(1) as f64;
    let name = model.name();
    if inliers < needed {
        anyhow::bail!("no reliable {name}: {inliers} inliers of {matches} matches, need ≥ {needed} (--min-inliers)");
    }
    if share < ratio {
        anyhow::bail!(
            "no reliable {name}: {inliers} inliers of {matches} matches ({:.1} %), need ≥ {:.1} % of the matches \
             (--min-inlier-ratio)",
            100.0 * share,
            100.0 * ratio
        );
    }
    Ok(())
}

/// Read and decode an image to grey values 0–255 within `budget` (checked on the header, before any pixel
/// is decoded); undecodable bytes and an image over the budget are invalid input naming the file.
async fn load(ctx: &Context, url: &str, budget: &Bounds) -> anyhow::Result<GrayImage> {
    let bytes = ctx.read(url).await?;
    decode_gray(url, &bytes, budget).map_err(|e| match e {
        DecodeError::OverBudget { .. } => invalid(format!("{e}; raise --max-pixels to admit it")),
        e => invalid(e.to_string()),
    })
}

/// Detect, describe and match: (keypoints in A, keypoints in B, mutual ratio-test correspondences).
fn features(
    a: &GrayImage,
    b: &GrayImage,
    detector: DetectorArg,
) -> anyhow::Result<(usize, usize, Vec<Correspondence>)> {
    let pair = |ka: &[Keypoint], kb: &[Keypoint], i: usize, j: usize| Correspondence {
        a: [ka[i].u, ka[i].v],
        b: [kb[j].u, kb[j].v],
    };
    Ok(match detector {
        DetectorArg::Kaze => {
            let (fa, fb) = (kaze(a, &KazeConfig::default())?, kaze(b, &KazeConfig::default())?);
            let m = match_surf(&fa.descriptors, &fb.descriptors, 0.8, true);
            let pairs = m.iter().map(|&(i, j, _)| pair(&fa.keypoints, &fb.keypoints, i, j)).collect();
            (fa.keypoints.len(), fb.keypoints.len(), pairs)
        }
        DetectorArg::Akaze | DetectorArg::AkazeUpright => {
            let cfg = AkazeConfig { upright: matches!(detector, DetectorArg::AkazeUpright), ..AkazeConfig::default() };
            let (fa, fb) = (akaze(a, &cfg)?, akaze(b, &cfg)?);
            let m = match_descriptors(&fa.descriptors, &fb.descriptors, 0.8, true);
            let pairs = m.iter().map(|m| pair(&fa.keypoints, &fb.keypoints, m.a, m.b)).collect();
            (fa.keypoints.len(), fb.keypoints.len(), pairs)
        }
    })
}

/// The JSON report: transform rows, counts and inlier residual statistics.
fn report(
    args: &Args,
    model: Model,
    keypoints: [usize; 2],
    pairs: &[Correspondence],
    fit: &RansacFit,
) -> serde_json::Value {
    let t = &fit.transform;
    let mut inlier_res: Vec<f64> = fit.residuals.iter().zip(&fit.inliers).filter(|p| *p.1).map(|p| *p.0).collect();
    inlier_res.sort_by(f64::total_cmp);
    let median = inlier_res.get(inlier_res.len() / 2).copied().unwrap_or(f64::NAN);
    json!({
        "a": args.a,
        "b": args.b,
        "model": model.name(),
        "detector": args.detector.to_possible_value().map(|v| v.get_name().to_owned()),
        "transform": (0..3).map(|r| (0..3).map(|c| t[(r, c)]).collect::<Vec<_>>()).collect::<Vec<_>>(),
        "keypoints": { "a": keypoints[0], "b": keypoints[1] },
        "matches": pairs.len(),
        "inliers": fit.inlier_count(),
        "residuals_px": { "rms": fit.rms, "median": median, "max": inlier_res.last().copied().unwrap_or(f64::NAN) },
        "ransac_iterations": fit.iterations,
    })
}

/// Both images side by side (A left), inlier matches as green lines, encoded as PNG.
fn draw(a: &GrayImage, b: &GrayImage, pairs: &[Correspondence], fit: &RansacFit) -> anyhow::Result<Vec<u8>> {
    let (w, h) = ((a.width() + b.width()) as u32, a.height().max(b.height()) as u32);
    let mut canvas = image::RgbImage::new(w, h);
    for (img, dx) in [(a, 0), (b, a.width())] {
        for r in 0..img.height() {
            for c in 0..img.width() {
                let g = img.get(c, r).clamp(0.0, 255.0) as u8;
                canvas.put_pixel((c + dx) as u32, r as u32, image::Rgb([g, g, g]));
            }
        }
    }
    for (p, _) in pairs.iter().zip(&fit.inliers).filter(|x| *x.1) {
        let (x0, y0, x1, y1) = (p.a[0], p.a[1], p.b[0] + a.width() as f64, p.b[1]);
        let steps = (x1 - x0).hypot(y1 - y0).ceil() as usize + 1;
        for i in 0..=steps {
            let t = i as f64 / steps as f64;
            let (x, y) = (x0 + t * (x1 - x0), y0 + t * (y1 - y0));
            if x >= 0.0 && y >= 0.0 && (x as u32) < w && (y as u32) < h {
                canvas.put_pixel(x as u32, y as u32, image::Rgb([40, 220, 60]));
            }
        }
    }
    let mut out = std::io::Cursor::new(Vec::new());
    canvas.write_to(&mut out, image::ImageFormat::Png).context("encoding the matches PNG")?;
    Ok(out.into_inner())
}
