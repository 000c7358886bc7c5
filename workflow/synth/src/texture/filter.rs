//! Hash noise and box-filtered primitives: every pattern is integrated over the sample's footprint, so the
//! texture is anti-aliased at any resolution without a bitmap.

/// A well-mixed 32-bit hash of a seed and two integers.
pub fn hash(seed: u64, a: i64, b: i64) -> u32 {
    let mut x = seed ^ (a as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ (b as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
    x ^= x >> 33;
    x = x.wrapping_mul(0xFF51_AFD7_ED55_8CCD);
    x ^= x >> 33;
    x = x.wrapping_mul(0xC4CE_B9FE_1A85_EC53);
    (x >> 32) as u32
}

/// A uniform value in [0, 1) from a hash.
pub fn unit(seed: u64, a: i64, b: i64) -> f32 {
    (hash(seed, a, b) >> 8) as f32 / (1u32 << 24) as f32
}

/// Smoothly interpolated value noise in [0, 1] with unit wavelength.
pub fn value_noise(seed: u64, x: f64, y: f64) -> f32 {
    let (fx, fy) = (x.floor(), y.floor());
    let (ix, iy) = (fx as i64, fy as i64);
    let s = |t: f64| (t * t * (3.0 - 2.0 * t)) as f32;
    let (u, v) = (s(x - fx), s(y - fy));
    let c = |dx: i64, dy: i64| unit(seed, ix + dx, iy + dy);
    let top = c(0, 0) + (c(1, 0) - c(0, 0)) * u;
    let bottom = c(0, 1) + (c(1, 1) - c(0, 1)) * u;
    top + (bottom - top) * v
}

/// Weight of detail of `wavelength` seen through a footprint: 1 when resolved, 0 when averaged away.
pub fn resolved(wavelength: f64, footprint: f64) -> f32 {
    let r = footprint / wavelength;
    (((1.0 - r) / 0.5).clamp(0.0, 1.0)) as f32
}

/// Sum of noise octaves from `wavelength` down by halves, each faded to its mean when unresolved; in [−1, 1].
pub fn fbm(seed: u64, x: f64, y: f64, wavelength: f64, octaves: u32, footprint: f64) -> f32 {
    let (mut sum, mut amp, mut norm, mut wl) = (0.0f32, 1.0f32, 0.0f32, wavelength);
    for k in 0..octaves {
        let w = resolved(wl, footprint);
        if w > 0.0 {
            sum += amp * w * (2.0 * value_noise(seed.wrapping_add(u64::from(k)), x / wl, y / wl) - 1.0);
        }
        norm += amp;
        amp *= 0.6;
        wl *= 0.5;
    }
    sum / norm
}

/// Share of the box [x − fp/2, x + fp/2] inside [a, b].
pub fn stripe(x: f64, a: f64, b: f64, fp: f64) -> f32 {
    let h = fp.max(1e-4) / 2.0;
    (((x + h).min(b) - (x - h).max(a)).max(0.0) / (2.0 * h)) as f32
}

/// Share of the box around `x` covered by pulses [k·period + start, k·period + start + len].
pub fn pulses(x: f64, period: f64, start: f64, len: f64, fp: f64) -> f32 {
    let integral = |y: f64| {
        let z = y - start;
        let k = (z / period).floor();
        k * len + (z - k * period).clamp(0.0, len)
    };
    let h = fp.max(1e-4) / 2.0;
    ((integral(x + h) - integral(x - h)) / (2.0 * h)).clamp(0.0, 1.0) as f32
}

/// Coverage of a shape from its signed distance (positive inside) for shapes larger than the footprint.
pub fn sdf_cover(sd: f64, fp: f64) -> f32 {
    (0.5 + sd / fp.max(1e-4)).clamp(0.0, 1.0) as f32
}

/// Linear blend of two colours.
pub fn mix(a: [f32; 3], b: [f32; 3], w: f32) -> [f32; 3] {
    [a[0] + (b[0] - a[0]) * w, a[1] + (b[1] - a[1]) * w, a[2] + (b[2] - a[2]) * w]
}

/// A grey colour.
pub fn grey(v: f32) -> [f32; 3] {
    [v, v, v]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_filters_integrate_exactly() {
        assert!((stripe(0.0, -0.05, 0.05, 1.0) - 0.1).abs() < 1e-6);
        assert!((stripe(0.0, -0.05, 0.05, 0.01) - 1.0).abs() < 1e-6);
        // Dashes 3 m on, 6 m off seen through a 90 m footprint cover a third.
        assert!((pulses(17.0, 9.0, 0.0, 3.0, 90.0) - 1.0 / 3.0).abs() < 1e-6);
        assert_eq!(pulses(1.5, 9.0, 0.0, 3.0, 0.1), 1.0);
        assert_eq!(pulses(5.0, 9.0, 0.0, 3.0, 0.1), 0.0);
    }

    #[test]
    fn noise_is_deterministic_and_bounded() {
        for i in 0..1000 {
            let (x, y) = (f64::from(i) * 0.37, f64::from(i) * -0.11);
            let n = fbm(5, x, y, 2.0, 5, 0.01);
            assert!((-1.0..=1.0).contains(&n));
            assert_eq!(n, fbm(5, x, y, 2.0, 5, 0.01));
        }
    }
}
