//! A pole cadastre as an agency would deliver it for the synthetic world: every pole-like object's base
//! with a seeded position error (poles σ ≈ 5–10 cm, trees σ ≈ 30–50 cm; Meyer et al. 2023 §4.1), and the defects
//! of real registers: objects missing from the cadastre, and objects still listed but gone in reality.
//! Plain values; the GeoPackage is written by the services.

use std::fmt::Write as _;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::world::{Pole, PoleClass, World};

/// How the cadastre deviates from the world.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CadastreErrors {
    /// Position standard deviation (each of east, north) of poles, lights, signs, traffic lights, metres.
    pub pole_sigma_m: f64,
    /// Position standard deviation of trees, metres.
    pub tree_sigma_m: f64,
    /// Share of real objects missing from the cadastre.
    pub missing_share: f64,
    /// Cadastre entries of removed objects, as a share of the real objects.
    pub gone_share: f64,
}

impl CadastreErrors {
    /// 7 cm for poles, 40 cm for trees, 5 % missing, 3 % gone.
    pub fn typical() -> Self {
        Self { pole_sigma_m: 0.07, tree_sigma_m: 0.4, missing_share: 0.05, gone_share: 0.03 }
    }
}

/// What is wrong with an object, if anything.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Defect {
    /// Exists and is listed (with its position error).
    None,
    /// Exists but is not in the cadastre.
    Missing,
    /// In the cadastre but not in the world.
    Gone,
}

impl Defect {
    /// Its name in `truth/poles.csv`.
    pub fn name(self) -> &'static str {
        match self {
            Defect::None => "none",
            Defect::Missing => "missing_from_cadastre",
            Defect::Gone => "gone_in_reality",
        }
    }
}

/// One object of the truth table: a real pole (maybe unlisted) or a listed ghost.
#[derive(Clone, Debug, PartialEq)]
pub struct CadastreObject {
    /// Index into `World::poles` (`None` for a ghost).
    pub world_id: Option<u32>,
    /// Cadastre feature id (`None` when missing from the cadastre).
    pub cadastre_id: Option<i64>,
    /// Class name: `light`, `sign`, `traffic_light`, `tree`.
    pub class: &'static str,
    /// Diameter, metres (as listed; the real one for real objects).
    pub diameter_m: f64,
    /// True base (east, north), campaign CRS; a ghost's former position.
    pub truth: [f64; 2],
    /// Listed position (east, north), campaign CRS, when listed.
    pub listed: Option<[f64; 2]>,
    /// The defect.
    pub defect: Defect,
}

/// The cadastre class name of a world object class.
pub fn class_name(class: PoleClass) -> &'static str {
    match class {
        PoleClass::StreetLight => "light",
        PoleClass::SignPost => "sign",
        PoleClass::TrafficLight => "traffic_light",
        PoleClass::Tree => "tree",
    }
}

/// The cadastre of `world`: real objects (listed or missing) then ghosts. Deterministic from `seed`.
pub fn cadastre(world: &World, errors: &CadastreErrors, seed: u64) -> Vec<CadastreObject> {
    cadastre_of(&world.poles, errors, seed, 1)
}

/// The cadastre entries of `poles` (`world_id` = each pole's id), feature ids from `first_id` on: real objects
/// (listed or missing) then ghosts between neighbouring poles of one class. Deterministic from `seed`.
pub fn cadastre_of(poles: &[Pole], errors: &CadastreErrors, seed: u64, first_id: i64) -> Vec<CadastreObject> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0xCADA_57E0);
    let mut normal = move || {
        let (u1, u2): (f64, f64) = (rng.random_range(f64::MIN_POSITIVE..1.0), rng.random_range(0.0..1.0));
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    };
    let mut objects = Vec::with_capacity(poles.len());
    let mut next_id = first_id;
    for pole in poles {
        let sigma = if pole.class == PoleClass::Tree { errors.tree_sigma_m } else { errors.pole_sigma_m };
        let error = [normal() * sigma, normal() * sigma];
        // A uniform deviate from the same stream decides the defect (Φ of a normal would do as well).
        let missing = normal().abs() < quantile_half(errors.missing_share);
        let listed = (!missing).then(|| [pole.base[0] + error[0], pole.base[1] + error[1]]);
        let cadastre_id = listed.map(|_| {
            next_id += 1;
            next_id - 1
        });
        objects.push(CadastreObject {
            world_id: Some(pole.id),
            cadastre_id,
            class: class_name(pole.class),
            diameter_m: pole.diameter,
            truth: [pole.base[0], pole.base[1]],
            listed,
            defect: if missing { Defect::Missing } else { Defect::None },
        });
    }
    let ghosts = (poles.len() as f64 * errors.gone_share).round() as usize;
    for (k, pair) in poles.windows(2).filter(|w| w[0].class == w[1].class).enumerate() {
        if k >= ghosts {
            break;
        }
        // A removed object of the same row: halfway between two neighbouring ones of its class.
        let (a, b) = (&pair[0], &pair[1]);
        let at = [(a.base[0] + b.base[0]) / 2.0, (a.base[1] + b.base[1]) / 2.0];
        objects.push(CadastreObject {
            world_id: None,
            cadastre_id: Some(next_id),
            class: class_name(a.class),
            diameter_m: a.diameter,
            truth: at,
            listed: Some(at),
            defect: Defect::Gone,
        });
        next_id += 1;
    }
    objects
}

/// The |z| below which a standard normal falls with probability `p` (bisection on erf; p in [0, 1)).
fn quantile_half(p: f64) -> f64 {
    let (mut lo, mut hi) = (0.0f64, 10.0f64);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if erf(mid / std::f64::consts::SQRT_2) < p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Abramowitz–Stegun 7.1.26 (|error| < 1.5e-7).
fn erf(x: f64) -> f64 {
    let t = 1.0 / (1.0 + 0.327_591_1 * x.abs());
    let poly =
        t * (0.254_829_592 + t * (-0.284_496_736 + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    (1.0 - poly * (-x * x).exp()).copysign(x)
}

/// `truth/poles.csv`: every object with its true and listed position and its defect.
pub fn truth_csv(objects: &[CadastreObject]) -> Vec<u8> {
    let mut s = String::from("world_id,cadastre_id,class,diameter_m,true_e,true_n,listed_e,listed_n,defect\n");
    let opt = |v: Option<String>| v.unwrap_or_default();
    for o in objects {
        let listed = o.listed.map_or_else(|| ",".to_owned(), |[e, n]| format!("{e:.4},{n:.4}"));
        let _ = writeln!(
            s,
            "{},{},{},{:.3},{:.4},{:.4},{listed},{}",
            opt(o.world_id.map(|v| v.to_string())),
            opt(o.cadastre_id.map(|v| v.to_string())),
            o.class,
            o.diameter_m,
            o.truth[0],
            o.truth[1],
            o.defect.name()
        );
    }
    s.into_bytes()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::{Preset, WorldConfig};

    #[test]
    fn errors_follow_the_class_sigmas_and_defects_their_shares() {
        let world = World::generate(&WorldConfig::new(Preset::Tiny, 3)).unwrap();
        let errors = CadastreErrors { missing_share: 0.2, ..CadastreErrors::typical() };
        let objects = cadastre(&world, &errors, 11);
        let (mut pole_sq, mut tree_sq, mut np, mut nt, mut missing) = (0.0, 0.0, 0, 0, 0);
        for o in objects.iter().filter(|o| o.world_id.is_some()) {
            let Some([e, n]) = o.listed else {
                missing += 1;
                continue;
            };
            let sq = (e - o.truth[0]).powi(2) + (n - o.truth[1]).powi(2);
            if o.class == "tree" {
                (tree_sq, nt) = (tree_sq + sq, nt + 1);
            } else {
                (pole_sq, np) = (pole_sq + sq, np + 1);
            }
        }
        assert!(np > 30 && nt > 30, "{np} poles, {nt} trees");
        // Per-axis RMS: the σ within sampling error (±30 % at n ≥ 30 is > 3 standard errors).
        let (rp, rt) = ((pole_sq / (2.0 * np as f64)).sqrt(), (tree_sq / (2.0 * nt as f64)).sqrt());
        assert!((rp - 0.07).abs() < 0.021, "poles {rp}");
        assert!((rt - 0.4).abs() < 0.12, "trees {rt}");
        let share = f64::from(missing) / world.poles.len() as f64;
        assert!((share - 0.2).abs() < 0.08, "missing share {share}");
        let ghosts = objects.iter().filter(|o| o.defect == Defect::Gone).count();
        assert_eq!(ghosts, (world.poles.len() as f64 * 0.03).round() as usize);
        // Ids are unique and only listed objects have one.
        let mut ids: Vec<i64> = objects.iter().filter_map(|o| o.cadastre_id).collect();
        let listed = objects.iter().filter(|o| o.listed.is_some()).count();
        ids.sort_unstable();
        ids.dedup();
        assert_eq!(ids.len(), listed);
    }

    #[test]
    fn quantile_inverts_the_two_sided_normal() {
        assert!((quantile_half(0.6827) - 1.0).abs() < 1e-3);
        assert!((quantile_half(0.9545) - 2.0).abs() < 2e-3);
        assert!(quantile_half(0.0) < 1e-9);
    }
}
