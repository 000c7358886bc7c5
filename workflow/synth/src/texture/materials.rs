//! Surface materials: asphalt with repairs, manholes, kerbstones, sidewalk paving, yards.

use super::Rgb;
use super::filter::{fbm, grey, mix, pulses, resolved, sdf_cover, stripe, unit};
use crate::world::{Epoch, Place};

/// Asphalt: low-frequency tone, grain, and rectangular repairs (some newer than the aerial flight).
pub fn asphalt(seed: u64, epoch: Epoch, x: f64, y: f64, fp: f64) -> Rgb {
    let tone = 0.17 + 0.035 * fbm(seed ^ 11, x, y, 6.0, 3, fp) + 0.03 * fbm(seed ^ 12, x, y, 0.4, 4, fp);
    let cell = 7.0;
    let (cx, cy) = ((x / cell).floor() as i64, (y / cell).floor() as i64);
    let r = unit(seed ^ 13, cx, cy);
    // 12 % of cells carry a repair; a fifth of those were made between the epochs.
    let present = r < 0.12 && (epoch == Epoch::Mobile || r > 0.024);
    if !present {
        return grey(tone);
    }
    let (u0, v0) = (0.5 + 2.0 * f64::from(unit(seed ^ 14, cx, cy)), 0.5 + 2.0 * f64::from(unit(seed ^ 15, cx, cy)));
    let (lu, lv) = (1.5 + 3.0 * f64::from(unit(seed ^ 16, cx, cy)), 1.0 + 2.5 * f64::from(unit(seed ^ 17, cx, cy)));
    let (lx, ly) = (x - cx as f64 * cell, y - cy as f64 * cell);
    let cover = stripe(lx, u0, u0 + lu, fp) * stripe(ly, v0, v0 + lv, fp);
    let patch = if r < 0.06 { 0.11 } else { 0.25 };
    grey(tone + (patch - 0.17) * cover)
}

/// Manholes: cast-iron discs on the lane centres every ~37 m.
pub fn manholes(place: &Place, base: Rgb, fp: f64) -> Rgb {
    let st = place.street;
    let period = 37.0 + f64::from(st.key % 5);
    let s = place.station.s.rem_euclid(period) - period / 2.0;
    let t = place.station.t - st.drive_offset();
    let d = s.hypot(t);
    if d > 0.6 + fp {
        return base;
    }
    let disc = sdf_cover(0.3 - d, fp);
    let ring = sdf_cover(0.035 - (d - 0.27).abs(), fp) * resolved(0.07, fp);
    mix(mix(base, grey(0.09), disc), grey(0.3), ring * disc)
}

/// Granite kerbstones with joints every metre.
pub fn kerb(seed: u64, s: f64, x: f64, y: f64, fp: f64) -> Rgb {
    let joint = pulses(s, 1.0, 0.0, 0.012, fp);
    grey(0.52 + 0.05 * fbm(seed ^ 21, x, y, 0.3, 3, fp) - 0.3 * joint)
}

/// Sidewalk paving: a per-street slab size and tone, per-slab variation and joints.
pub fn paving(seed: u64, street: u32, local: (f64, f64), x: f64, y: f64, fp: f64) -> Rgb {
    let kind = unit(seed ^ 31, i64::from(street), 0);
    let size = [0.3, 0.4, 0.5, 0.2][(kind * 4.0) as usize % 4];
    let tone = 0.42 + 0.15 * unit(seed ^ 32, i64::from(street), 1);
    let (s, t) = local;
    // Running bond: every other row shifted by half a slab.
    let row = (t / size).floor();
    let shift = if row as i64 % 2 == 0 { 0.0 } else { size / 2.0 };
    let slab = unit(seed ^ 33, ((s + shift) / size).floor() as i64, row as i64);
    let vary = 0.06 * (slab - 0.5) * resolved(size, fp);
    let joints = 1.0 - (1.0 - pulses(s + shift, size, 0.0, 0.01, fp)) * (1.0 - pulses(t, size, 0.0, 0.01, fp));
    let c = tone + vary + 0.02 * fbm(seed ^ 34, x, y, 2.0, 2, fp) - 0.2 * joints;
    [c, c * 0.97, c * 0.93]
}

/// Yards, courtyards and verges: gravel and grass.
pub fn yard(seed: u64, x: f64, y: f64, fp: f64) -> Rgb {
    let g = fbm(seed ^ 41, x, y, 8.0, 4, fp);
    let grass = mix([0.30, 0.27, 0.22], [0.16, 0.26, 0.10], (0.5 + g).clamp(0.0, 1.0));
    let grain = 0.03 * fbm(seed ^ 42, x, y, 0.2, 3, fp);
    [grass[0] + grain, grass[1] + grain, grass[2] + grain]
}
