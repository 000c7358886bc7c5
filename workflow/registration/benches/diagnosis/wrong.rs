//! A diagnosis of the aerial points that are NOT correct: for each, what the MM ray truly hits, the
//! MM two-ray height against the ortho plane, the other points of its panorama, and per aerial frame the
//! corner search (transfer, NCC peak and runner-up, accepted position) against the true pixel.

use plumbline_geo::{Map, Point3, Vec3};
use plumbline_registration::TileResultV1;
use plumbline_registration::aerial::ImageTrace;
use plumbline_registration::mm::intersect_rays;
use plumbline_synth::world::Epoch;

use crate::support::Campaign;

/// One line per wrong point (horizontal error above `limit_m`), each with its per-frame lines.
pub fn explain(campaign: &Campaign, result: &TileResultV1, traces: &[Vec<ImageTrace>], limit_m: f64) -> Vec<String> {
    let mut out = Vec::new();
    for (i, (d, traces)) in result.images.iter().zip(traces).enumerate() {
        let prefix = format!("{}:", d.image);
        let ties: Vec<_> = result.ties.iter().filter(|t| t.id.0.starts_with(&prefix) && t.aerial.is_some()).collect();
        let errors: Vec<[f64; 3]> = ties.iter().map(|t| error(campaign, t).unwrap_or([f64::NAN; 3])).collect();
        let good: Vec<[f64; 3]> = errors.iter().filter(|e| e[0].hypot(e[1]) <= limit_m).copied().collect();
        for (t, e) in ties.iter().zip(&errors) {
            if e[0].hypot(e[1]) <= limit_m {
                continue;
            }
            let slot: usize = t.id.0[prefix.len()..].parse().unwrap_or(usize::MAX);
            out.push(format!(
                "{}: error E {:+.2} N {:+.2} H {:+.2} m; {} correct points of the panorama, their median error E {:+.3} N {:+.3}; {}; {}",
                t.id.0,
                e[0],
                e[1],
                e[2],
                good.len(),
                median(good.iter().map(|g| g[0])),
                median(good.iter().map(|g| g[1])),
                truth_hit(campaign, t),
                mm_height(campaign, t),
            ));
            if !out.last().is_some_and(|l: &String| l.starts_with("    neighbours")) {
                out.push(format!("    neighbours: {}; {}", neighbours(campaign, result, i), scatter(traces)));
            }
            let Some(g) = campaign.true_ground(t) else { continue };
            for trace in traces {
                let Some(a) = trace.attempts.iter().find(|a| a.slot == slot) else { continue };
                let truth = campaign.aerial_pixel(&trace.frame, &g).unwrap_or([f64::NAN; 2]);
                let rel = |p: Option<[f64; 2]>| {
                    p.map_or("–".into(), |p| format!("{:+.1},{:+.1}", p[0] - truth[0], p[1] - truth[1]))
                };
                out.push(format!(
                    "    {} (radius {}): − true px: transfer {} peak {} matched {}; NCC {:.3} runner-up {:.3}, roundness {:.2}; RANSAC {} kept {}",
                    trace.frame,
                    trace.radius,
                    rel(Some(a.predicted)),
                    rel(a.peak),
                    rel(a.matched),
                    a.score.unwrap_or(f64::NAN),
                    a.second.unwrap_or(f64::NAN),
                    a.roundness,
                    trace.ransac.contains(&slot),
                    trace.kept.contains(&slot),
                ));
            }
        }
    }
    out
}

/// The fate and median horizontal error of the panoramas within two places of panorama `i`.
fn neighbours(campaign: &Campaign, result: &TileResultV1, i: usize) -> String {
    let lo = i.saturating_sub(2);
    let items: Vec<String> = (lo..(i + 3).min(result.images.len()))
        .filter(|&k| k != i)
        .map(|k| {
            let d = &result.images[k];
            let prefix = format!("{}:", d.image);
            let e: Vec<[f64; 3]> =
                result.ties.iter().filter(|t| t.id.0.starts_with(&prefix)).filter_map(|t| error(campaign, t)).collect();
            let fate = d.discarded.as_ref().map_or("matched".to_owned(), |r| r.key());
            let (me, mn) = (median(e.iter().map(|e| e[0])), median(e.iter().map(|e| e[1])));
            format!("{} {fate} {} pts, median error E {me:+.2} N {mn:+.2}", d.image, e.len())
        })
        .collect();
    items.join(" | ")
}

/// The spread of the kept corners of the first frame with any (their transfers), along and across their
/// principal direction, metres at 12 cm: a patch held by one straight line has almost no spread across it.
fn scatter(traces: &[ImageTrace]) -> String {
    let Some(tr) = traces.iter().find(|t| !t.kept.is_empty()) else { return "no kept corners".into() };
    let p: Vec<[f64; 2]> = tr.attempts.iter().filter(|a| tr.kept.contains(&a.slot)).map(|a| a.predicted).collect();
    let n = p.len() as f64;
    let m = [p.iter().map(|q| q[0]).sum::<f64>() / n, p.iter().map(|q| q[1]).sum::<f64>() / n];
    let (mut a, mut b, mut c) = (0.0, 0.0, 0.0);
    for q in &p {
        let (x, y) = (q[0] - m[0], q[1] - m[1]);
        (a, b, c) = (a + x * x / n, b + x * y / n, c + y * y / n);
    }
    let (mid, half) = (0.5 * (a + c), (0.25 * (a - c) * (a - c) + b * b).sqrt());
    let s = |v: f64| v.max(0.0).sqrt() * 0.12;
    format!(
        "{} kept corners in {}, spread {:.2} m along / {:.2} m across",
        p.len(),
        tr.frame,
        s(mid + half),
        s(mid - half)
    )
}

fn median(v: impl Iterator<Item = f64>) -> f64 {
    let mut v: Vec<f64> = v.collect();
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

fn error(campaign: &Campaign, t: &plumbline_adjustment::TiePoint) -> Option<[f64; 3]> {
    let a = t.aerial.as_ref()?;
    let g = campaign.true_ground(t)?;
    Some([a.position[0] - g.x(), a.position[1] - g.y(), a.position[2] - g.z()])
}

/// The true pose of a tie's panorama (image id before ':') and its ray cast at the MM epoch.
fn true_ray(campaign: &Campaign, t: &plumbline_adjustment::TiePoint) -> Option<(Point3<Map>, Vec3<Map>)> {
    let image = t.id.0.split(':').next()?;
    let (_, pose) = campaign.truth.iter().find(|(id, _)| id == image)?;
    let cam = campaign.rig.mount.camera_pose(pose);
    let d = Vec3::new(t.rays[0].direction[0], t.rays[0].direction[1], t.rays[0].direction[2]);
    Some((cam.translation, cam.rotation.apply(&d)))
}

/// What the first ray truly hits: surface, height above the ground, and how far from where the same ray
/// meets the ground plane (the ortho-projection's displacement of that surface).
fn truth_hit(campaign: &Campaign, t: &plumbline_adjustment::TiePoint) -> String {
    let Some((o, d)) = true_ray(campaign, t) else { return "no truth".into() };
    let Some(hit) = campaign.world.trace(&o.p, &d.v, 200.0, Epoch::Mobile) else { return "ray hits nothing".into() };
    let g = plumbline_geo::dg::intersect_height(&o, &d, campaign.ground_height);
    let shift = g.map_or(f64::NAN, |g| (g.x() - hit.point.x).hypot(g.y() - hit.point.y));
    format!(
        "truth: {:?} {:.2} m above ground, {:.2} m from the ray's ground point, range {:.1} m",
        hit.surface,
        hit.point.z - campaign.ground_height,
        shift,
        hit.t
    )
}

/// The MM intersection of the tie's rays from the DG poses, its height above the ortho plane of the first
/// panorama and its distance from the rays.
fn mm_height(campaign: &Campaign, t: &plumbline_adjustment::TiePoint) -> String {
    let rays: Vec<(Point3<Map>, Vec3<Map>)> = t
        .rays
        .iter()
        .filter_map(|r| {
            let p = campaign.panoramas.iter().find(|p| (p.time - r.time).abs() < 1e-6)?;
            let cam = campaign.rig.mount.camera_pose(&p.pose);
            let d = Vec3::new(r.direction[0], r.direction[1], r.direction[2]);
            Some((cam.translation, cam.rotation.apply(&d)))
        })
        .collect();
    let Some(first) = rays.first() else { return "no MM rays".into() };
    let plane = first.0.z() - campaign.rig.camera_height;
    match intersect_rays(&rays, 0.0) {
        Ok(hit) => format!(
            "MM {} rays: {:+.2} m above the ortho plane, miss {:.3} m, angle {:.1}°",
            rays.len(),
            hit.point.z() - plane,
            hit.miss,
            hit.angle.to_degrees()
        ),
        Err(e) => format!("MM rays: {e}"),
    }
}

/// The NCC ambiguity of the accepted corner searches that reached the end of §3.8, true (within `true_px`
/// of the true pixel) against false: quantiles 0/1/10/50/90 of (1 − runner-up) / (1 − peak) and of the
/// template's roundness.
pub fn ambiguity(campaign: &Campaign, result: &TileResultV1, traces: &[Vec<ImageTrace>], true_px: f64) -> String {
    let (mut good, mut bad) = (Vec::new(), Vec::new());
    let (mut round_good, mut round_bad) = (Vec::new(), Vec::new());
    for (d, traces) in result.images.iter().zip(traces) {
        let prefix = format!("{}:", d.image);
        for t in result.ties.iter().filter(|t| t.id.0.starts_with(&prefix)) {
            let (Ok(slot), Some(g)) = (t.id.0[prefix.len()..].parse::<usize>(), campaign.true_ground(t)) else {
                continue;
            };
            for trace in traces.iter().filter(|tr| tr.kept.contains(&slot)) {
                let Some(a) = trace.attempts.iter().find(|a| a.slot == slot) else { continue };
                let (Some(m), Some(s), Some(r)) = (a.matched, a.score, a.second) else { continue };
                let Some(p) = campaign.aerial_pixel(&trace.frame, &g) else { continue };
                let ratio = (1.0 - r) / (1.0 - s).max(1e-6);
                if (m[0] - p[0]).hypot(m[1] - p[1]) <= true_px {
                    good.push(ratio);
                    round_good.push(a.roundness);
                } else {
                    bad.push(ratio);
                    round_bad.push(a.roundness);
                }
            }
        }
    }
    let q = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        [0.0, 0.01, 0.1, 0.5, 0.9]
            .map(|q| v.get(((v.len() as f64 - 1.0) * q).round() as usize).copied().unwrap_or(f64::NAN))
    };
    format!(
        "(1 − runner-up)/(1 − peak) q0/1/10/50/90: true {} {:.2?}, false {} {:.2?}; roundness: true {:.2?}, false {:.2?}",
        good.len(),
        q(&mut good),
        bad.len(),
        q(&mut bad),
        q(&mut round_good),
        q(&mut round_bad)
    )
}
