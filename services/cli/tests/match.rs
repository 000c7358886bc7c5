//! End-to-end tests of `plumbline match` on a synthetic image pair with a known similarity.
#![allow(clippy::unwrap_used)]

mod support;

use support::plumbline;

/// A blob field rendered as 8-bit PNG; B shows A's point p at s·R·p + t, darker.
fn write_pair(dir: &tempfile::TempDir) -> (String, String, [[f64; 3]; 2]) {
    let blobs: Vec<[f64; 4]> = (0..220u32)
        .map(|i| {
            // SplitMix64 of (blob, field): an even, seed-free spread of positions, sizes and signs.
            let h = |k: u64| {
                let mut z = (u64::from(i) * 8 + k).wrapping_mul(0x9E37_79B9_7F4A_7C15);
                z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
                z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
                ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
            };
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
