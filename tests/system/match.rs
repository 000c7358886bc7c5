//! End-to-end tests of `plumbline match` on a synthetic image pair with a known similarity, on a pair with no
//! solution, and on images over the pixel budget.
#![allow(clippy::unwrap_used)]

use crate::support;

use plumbline_testkit::images::{png_bomb, png_claiming};
use support::plumbline;

/// SplitMix64 of `k`, in [0, 1).
fn unit(k: u64) -> f64 {
    let mut z = k.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
}

/// A blob field rendered as 8-bit PNG; B shows A's point p at s·R·p + t, darker.
fn write_pair(dir: &tempfile::TempDir) -> (String, String, [[f64; 3]; 2]) {
    let blobs: Vec<[f64; 4]> = (0..220u32)
        .map(|i| {
            // SplitMix64 of (blob, field): an even, seed-free spread of positions, sizes and signs.
            let h = |k: u64| unit(u64::from(i) * 8 + k);
            [h(1) * 256.0, h(2) * 256.0, 1.5 + 4.5 * h(3), if h(4) > 0.5 { 70.0 } else { -70.0 }]
        })
        .collect();
    let f = |x: f64, y: f64| {
        128.0
            + blobs
                .iter()
                .map(|b| b[3] * (-((x - b[0]).powi(2) + (y - b[1]).powi(2)) / (2.0 * b[2] * b[2])).exp())
                .sum::<f64>()
    };
    let (angle, scale, t) = (0.3f64, 0.9, [20.0, -8.0]);
    let (s, c) = (scale * angle.sin(), scale * angle.cos());
    let truth = [[c, -s, t[0]], [s, c, t[1]]];
    let det = c * c + s * s;
    let save = |name: &str, g: &dyn Fn(f64, f64) -> f64| {
        let img = image::GrayImage::from_fn(256, 256, |x, y| {
            image::Luma([g(f64::from(x) + 0.5, f64::from(y) + 0.5).clamp(0.0, 255.0) as u8])
        });
        let path = dir.path().join(name);
        img.save(&path).unwrap();
        path.to_str().unwrap().to_owned()
    };
    let a = save("a.png", &|x, y| f(x, y));
    let b = save("b.png", &|u, v| {
        let (du, dv) = (u - t[0], v - t[1]);
        0.7 * f((c * du + s * dv) / det, (-s * du + c * dv) / det) + 25.0
    });
    (a, b, truth)
}

#[test]
fn match_prints_the_known_similarity_and_draws_the_matches() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b, truth) = write_pair(&dir);
    for detector in ["akaze", "kaze"] {
        let out = dir.path().join(format!("matches-{detector}.png"));
        let args =
            ["match", &a, &b, "--model", "similarity", "--detector", detector, "--matches", out.to_str().unwrap()];
        let run = plumbline(&args).run();
        run.success();
        let report: serde_json::Value = serde_json::from_str(&run.stdout).unwrap();
        assert_eq!(report["detector"], detector);
        let t: Vec<Vec<f64>> = serde_json::from_value(report["transform"].clone()).unwrap();
        // The fitted mapping agrees with the truth to half a pixel over the image.
        for (x, y) in [(0.0, 0.0), (256.0, 0.0), (0.0, 256.0), (256.0, 256.0)] {
            for (row, tr) in t.iter().zip(&truth) {
                let (got, want) = (row[0] * x + row[1] * y + row[2], tr[0] * x + tr[1] * y + tr[2]);
                assert!((got - want).abs() < 0.5, "{detector}: {got} vs {want}\n{}", run.stdout);
            }
        }
        assert!(report["inliers"].as_u64().unwrap() >= 20, "{}", run.stdout);
        assert!(report["residuals_px"]["rms"].as_f64().unwrap() < 1.0);
        eprintln!("{}", run.stdout);
        let drawn = image::open(&out).unwrap();
        assert_eq!((drawn.width(), drawn.height()), (512, 256));
    }
    // The default minimum consensus (16 for a homography, 5 % of the matches) admits this real pair.
    let run = plumbline(&["match", &a, &b, "--model", "homography"]).run();
    run.success();
    let report: serde_json::Value = serde_json::from_str(&run.stdout).unwrap();
    assert!(report["inliers"].as_u64().unwrap() >= 16, "{}", run.stdout);
}

/// Two independent noise images have no transform between them. RANSAC still finds a few
/// chance inliers (a homography fits any four pairs exactly); `match` fails instead of printing a matrix.
#[test]
fn match_reports_no_solution_between_independent_images_and_prints_no_matrix() {
    let dir = tempfile::tempdir().unwrap();
    let noise = |name: &str, seed: u64| {
        // Noise smoothed over 2 × 2 px, so the detectors find blobs of a size features describe.
        let img = image::GrayImage::from_fn(256, 256, |x, y| {
            let v = |dx: u32, dy: u32| unit((seed << 40) | (u64::from((y + dy) / 2) << 20) | u64::from((x + dx) / 2));
            image::Luma([(255.0 * (v(0, 0) + v(1, 0) + v(0, 1) + v(1, 1)) / 4.0) as u8])
        });
        let path = dir.path().join(name);
        img.save(&path).unwrap();
        path.to_str().unwrap().to_owned()
    };
    let (a, b) = (noise("noise-a.png", 1), noise("noise-b.png", 2));
    for model in ["similarity", "affine", "homography"] {
        let out = dir.path().join(format!("matches-{model}.png"));
        let run = plumbline(&["match", &a, &b, "--model", model, "--matches", out.to_str().unwrap()]).run();
        run.failure_with(1);
        assert!(run.stdout.trim().is_empty(), "a matrix was printed:\n{}", run.stdout);
        assert!(!out.exists(), "matches were drawn");
        assert!(run.stderr.contains(&format!("no reliable {model}: ")), "{model}: {}", run.stderr);
        eprintln!("{}", run.stderr.trim());
    }
}

/// A PNG whose header claims 20000 × 20000 px (68 bytes) and a real 12000² decompression bomb are
/// invalid input (exit code 2) named with their size, refused on their header before any pixel is decoded.
#[test]
fn match_refuses_an_image_over_the_pixel_budget_naming_file_and_size() {
    let dir = tempfile::tempdir().unwrap();
    let (a, _, _) = write_pair(&dir);
    for (name, bytes, claim) in [
        ("forged.png", png_claiming(20_000, 20_000), "20000 × 20000 px"),
        ("bomb.png", png_bomb(12_000, 12_000), "12000 × 12000 px"),
    ] {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        let run = plumbline(&["match", &a, path.to_str().unwrap()]).run();
        run.failure_with(2);
        assert!(run.stderr.contains(&format!("{name}: {claim}")), "{}", run.stderr);
        assert!(run.stderr.contains("budget of 67.1 M px") && run.stderr.contains("--max-pixels"), "{}", run.stderr);
        assert!(run.stdout.is_empty());
    }
    // The budget is the option's: 256² px is one pixel too many for 65535.
    let run = plumbline(&["match", &a, &a, "--max-pixels", "65535"]).run();
    run.failure_with(2);
    assert!(run.stderr.contains("a.png: 256 × 256 px"), "{}", run.stderr);
}

#[test]
fn match_refuses_a_file_that_is_not_an_image() {
    let dir = tempfile::tempdir().unwrap();
    let (a, _, _) = write_pair(&dir);
    let bad = support::write(&dir, "notes.png", "not an image");
    let run = plumbline(&["match", &a, &bad]).run();
    run.failure_with(2);
    assert!(run.stderr.contains("notes.png"), "{}", run.stderr);
    plumbline(&["match", &a, "/nonexistent/b.png"]).run().failure_with(2);
}
