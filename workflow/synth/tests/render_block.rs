//! The aerial block: the planned overlaps hold when checked by projecting principal rays between images
//! (plumbline-geo's pinhole and ray/plane intersection), and every part of the world is seen at least twice.
#![allow(clippy::unwrap_used)]

use plumbline_geo::camera::{CameraModel, Pinhole, Pixel};
use plumbline_geo::dg::intersect_height;
use plumbline_geo::{Map, MapFromCamera, Point3};
use plumbline_synth::render::{AtErrors, BlockSpec, perturb_block, plan_block};
use plumbline_synth::world::{Preset, World, WorldConfig};

fn cam() -> Pinhole {
    Pinhole::new(1500, 1000, 8000.0, 8000.0, 750.0, 500.0, -0.5, 0.0).unwrap()
}

fn ground_of(pose: &MapFromCamera, px: Pixel, h: f64) -> Point3<Map> {
    let d = pose.rotation.apply(&cam().unproject(px).unwrap());
    intersect_height(&pose.translation, &d, h).unwrap()
}

fn pixel_in(pose: &MapFromCamera, p: &Point3<Map>) -> Option<Pixel> {
    let v = pose.inverse().transform_point(p) - Point3::origin();
    cam().project(&v).filter(|px| cam().contains(*px))
}

#[test]
fn overlaps_and_coverage_hold() {
    let w = World::generate(&WorldConfig::new(Preset::Tiny, 3)).unwrap();
    let spec = BlockSpec::standard();
    let poses = plan_block(&w, &cam(), &spec);
    let h = w.config.ground_height;
    assert!((poses[0].translation.z() - h - 0.12 * 8000.0).abs() < 1e-9);
    let centre = Pixel::new(750.0, 500.0);
    let (mut forward, mut side) = (0, 0);
    for (i, a) in poses.iter().enumerate() {
        for b in &poses[i + 1..] {
            // Where b's principal ray meets the ground, in a's image: offset from a's centre = the base.
            if let Some(px) = pixel_in(a, &ground_of(b, centre, h))
                && (px.v - 500.0).abs() < 1.0
                && ((px.u - 750.0).abs() - 0.4 * 1500.0).abs() < 2.0
            {
                forward += 1;
            }
            // The ground under a's north or south edge lies 30 % of a frame inside b's image.
            for edge in [Pixel::new(750.0, 0.0), Pixel::new(750.0, 1000.0)] {
                if let Some(px) = pixel_in(b, &ground_of(a, edge, h))
                    && (px.u - 750.0).abs() < 1.0
                    && ((px.v - 500.0).abs() - 0.2 * 1000.0).abs() < 2.0
                {
                    side += 1;
                }
            }
        }
    }
    let strips = poses.iter().filter(|p| (p.translation.x() - poses[0].translation.x()).abs() < 1e-6).count();
    let per_strip = poses.len() / strips;
    assert_eq!(forward, strips * (per_strip - 1), "60 % forward overlap between neighbours in each strip");
    assert_eq!(side, per_strip * (strips - 1), "30 % side overlap between neighbouring strips");
    let (lo, hi) = w.bounds();
    for i in 0..=20 {
        for j in 0..=20 {
            let p = Point3::new(
                lo[0] + (hi[0] - lo[0]) * f64::from(i) / 20.0,
                lo[1] + (hi[1] - lo[1]) * f64::from(j) / 20.0,
                h,
            );
            let seen = poses.iter().filter(|a| pixel_in(a, &p).is_some()).count();
            assert!(seen >= 2, "{p:?} seen {seen} times");
        }
    }
}

#[test]
fn at_errors_have_the_configured_spread() {
    let w = World::generate(&WorldConfig::new(Preset::District, 1)).unwrap();
    let spec = BlockSpec { gsd: 0.03, ..BlockSpec::standard() };
    let truth = plan_block(&w, &cam(), &spec);
    assert!(truth.len() > 500, "{}", truth.len());
    let err = AtErrors::typical();
    let delivered = perturb_block(&truth, &err, 4);
    let again = perturb_block(&truth, &err, 4);
    assert!(
        delivered
            .iter()
            .zip(&again)
            .all(|(a, b)| a.translation == b.translation && a.rotation.quaternion() == b.rotation.quaternion())
    );
    let n = truth.len() as f64;
    let pos = truth.iter().zip(&delivered).map(|(t, d)| (d.translation - t.translation).norm().powi(2)).sum::<f64>();
    let ang = truth.iter().zip(&delivered).map(|(t, d)| t.rotation.angle_to(&d.rotation).powi(2)).sum::<f64>();
    // Three independent components each: E|e|² = 3σ².
    let (sp, sa) = ((pos / (3.0 * n)).sqrt(), (ang / (3.0 * n)).sqrt());
    assert!((sp / err.position_m - 1.0).abs() < 0.08, "{sp}");
    assert!((sa / err.angle_rad - 1.0).abs() < 0.08, "{sa}");
}
