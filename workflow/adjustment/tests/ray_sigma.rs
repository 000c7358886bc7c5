//! Anisotropic tie rays: rays whose directions scatter ten times more in elevation than across (as ground
//! matches seen at grazing angles do) are weighed right with `TieRay::sigma_elevation`, and wrongly without.
#![allow(clippy::unwrap_used)]

use faer::Par;
use nalgebra::Vector3;
use plumbline_adjustment::{
    Adjustment, AdjustmentConfig, AdjustmentInput, AerialPoint, ObservationRef, ObservationSetV1, TiePoint, adjust,
};
use plumbline_fixtures::adjustment::*;
use plumbline_geo::{Point3, PositionInterpolation};
use rand::SeedableRng;

/// σ across the ray's vertical plane and in it (elevation), radians.
const ACROSS: f64 = 3e-4;
const ELEVATION: f64 = 3e-3;

/// Six ground points beside the first 30 s of a drive every 0.5 s, each seen from three epochs, with aerial
/// coordinates (2 cm horizontal, 4 cm vertical): every epoch carries rays enough to fix its pose. Each ray is
/// turned by N(0, `noise[0]`) across and N(0, `noise[1]`) in elevation along its `TieRay::tangents`, and
/// stated with σ `stated` [across, elevation (`None`: isotropic)].
fn ties(s: &Scene, seed: u64, noise: [f64; 2], stated: (f64, Option<f64>)) -> Vec<TiePoint> {
    let rng = &mut rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let (sh, sv) = (0.02, 0.04);
    let mut out = Vec::new();
    for (j, q) in (2u32..58).flat_map(|j| (0u32..6).map(move |q| (j, q))) {
        let i = j as usize * 5;
        let tr = &s.truth[i];
        let side = if q % 2 == 0 { 1.0 } else { -1.0 };
        let body = Vector3::new(3.0 + f64::from((j + q) % 7), side * (3.0 + f64::from(q + j % 3)), 2.5);
        let x = tr.position.p + tr.attitude.to_rotation().matrix() * body;
        let mut t = tie(s, &format!("g{j}.{q}"), x, &[i - 5, i, i + 5], 0.0, rng);
        for r in &mut t.rays {
            let [across, elevation] = r.tangents().map(Vector3::from);
            let d = Vector3::from(r.direction) + across * gauss(rng) * noise[0] + elevation * gauss(rng) * noise[1];
            r.direction = d.normalize().into();
            (r.sigma, r.sigma_elevation) = stated;
        }
        let noisy = x + Vector3::new(gauss(rng) * sh, gauss(rng) * sh, gauss(rng) * sv);
        let covariance = [[sh * sh, 0.0, 0.0], [0.0, sh * sh, 0.0], [0.0, 0.0, sv * sv]];
        t.aerial = Some(AerialPoint { position: noisy.into(), covariance });
        out.push(t);
    }
    out
}

/// The adjusted trajectory's horizontal RMS, and the RMS of the normalised residuals of the rays kept (their
/// tangent components, predicted from the corrected pose to the adjusted point, over the stated σ):
/// [across, elevation].
fn run(s: &Scene, ties: &[TiePoint], config: &AdjustmentConfig) -> (Adjustment, f64, [f64; 2]) {
    let obs = ObservationSetV1 { ties: ties.to_vec(), ..Default::default() };
    let m = mount();
    let input = AdjustmentInput { trajectory: &s.dg, observations: &obs, mount: &m, weak_links: &[] };
    let result = adjust(&input, config, Par::Seq).unwrap();
    let corrected = result.apply(&s.dg).unwrap();
    let errors = horizontal_errors(&corrected, &s.truth);
    let rejected: Vec<(usize, usize)> = result
        .rejected
        .iter()
        .filter_map(|r| match r.item {
            ObservationRef::TieRay { index, ray, .. } => Some((index, ray)),
            _ => None,
        })
        .collect();
    let mut sums = [0.0; 2];
    let mut n = 0.0;
    for (i, (tie, point)) in ties.iter().zip(&result.points).enumerate() {
        assert_eq!(tie.id, point.id);
        for (_, r) in tie.rays.iter().enumerate().filter(|(k, _)| !rejected.contains(&(i, *k))) {
            let pose = corrected.interpolate(r.time, PositionInterpolation::Linear).unwrap().pose();
            let u = m.to_camera(&pose, &Point3::from_vector(Vector3::from(point.position))).v.normalize();
            for ((t, sigma), sum) in r.tangents().iter().zip(r.sigmas()).zip(&mut sums) {
                *sum += (Vector3::from(*t).dot(&u) / sigma).powi(2);
            }
            n += 1.0;
        }
    }
    (result, rms(&errors[15..286]), sums.map(|v| (v / n).sqrt()))
}

fn rejected_rays(a: &Adjustment) -> usize {
    a.rejected.iter().filter(|r| matches!(r.item, ObservationRef::TieRay { .. })).count()
}

#[test]
fn the_elevation_sigma_makes_anisotropic_rays_consistent_and_isotropic_ones_are_not() {
    // Rightly weighted rays give the least-variance trajectory: on both seeds together, better than either
    // isotropic statement.
    let [(right, tight, loose), (right2, tight2, loose2)] = [11, 12].map(check);
    assert!(
        right + right2 < (tight + tight2).min(loose + loose2),
        "{right} {right2} {tight} {tight2} {loose} {loose2}"
    );
}

/// One seed's checks; the horizontal RMS with the rays stated right, isotropic across, isotropic elevation.
fn check(seed: u64) -> (f64, f64, f64) {
    let s = scene(60.0, 10.0, None, drift_and_jump(1e9), 0.05);
    let aniso = [ACROSS, ELEVATION];
    // The same anisotropic rays stated right, isotropic with the across σ, isotropic with the elevation σ.
    let sets = [
        ties(&s, seed, aniso, (ACROSS, Some(ELEVATION))),
        ties(&s, seed, aniso, (ACROSS, None)),
        ties(&s, seed, aniso, (ELEVATION, None)),
    ];
    let rays = 3 * sets[0].len();
    let runs: Vec<_> = sets.iter().map(|t| run(&s, t, &AdjustmentConfig::default())).collect();
    let found: Vec<_> = runs.iter().map(|(a, e, w)| (rejected_rays(a), *e, *w)).collect();
    eprintln!("seed {seed}: (rejected rays of {rays}, horizontal rms m, normalised residual rms [across, elevation]):");
    eprintln!("  right {:?}\n  across σ only {:?}\n  elevation σ only {:?}", found[0], found[1], found[2]);
    let [(right, right_rms, [a0, e0]), (tight, tight_rms, [_, e1]), (_, loose_rms, _)] = [found[0], found[1], found[2]];
    // Stated right: residuals are the errors less what the adjustment absorbs, so both normalised components
    // stay below 1 (across about √(1/3): three rays fix the point across), and snooping leaves the rays.
    assert!(a0 < 1.0 && e0 < 1.0 && a0 > 0.3 && e0 > 0.5, "{a0} {e0}");
    assert!(right * 100 <= rays, "{right} of {rays}");
    // Isotropic with the across σ: elevation residuals of several σ even after snooping rejects good rays by
    // the dozen.
    assert!(e1 > 3.0 && tight > 20 + 10 * right, "{e1} {tight}");
    assert!(right_rms < 0.02, "{right_rms}");
    (right_rms, tight_rms, loose_rms)
}
