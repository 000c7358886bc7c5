//! Levelling: roll and pitch from the mean specific force over the alignment window, standing or moving.
//!
//! The velocity increments are rotated into the body frame at the window's start with the gyros' relative
//! attitude, so Σ C_{b0←bk}·Δv_k = R₀ᵀ·∫f dt = R₀ᵀ·(v_end − v_start + g·T·up): the mean body specific force u
//! equals R₀ᵀ·w with w = ā + g·up in the map frame (ā from GNSS; zero at a standstill). Given the heading,
//! R₀ = Rz(ψ)·Ry(θ)·Rx(φ) (NED, Applanix), so Ry(θ)·Rx(φ)·u = h = Rz(ψ)ᵀ·w_NED: φ from the y component,
//! then θ from the rotation of the x–z components.

use nalgebra::{UnitQuaternion, Vector3};
use plumbline_geo::angle::wrap;

use crate::inputs::ImuSample;

/// The mean specific force over the samples ending in `[from, until]`, in the body frame at `from`, and the
/// time it covers; `None` without usable samples.
pub(crate) fn mean_specific_force(imu: &[ImuSample], from: f64, until: f64) -> Option<(Vector3<f64>, f64)> {
    let (mut sum, mut dt, mut rel) = (Vector3::zeros(), 0.0, UnitQuaternion::identity());
    for s in imu.iter().filter(|s| s.time > from && s.time <= until) {
        let half = UnitQuaternion::from_scaled_axis(s.delta_theta.v * 0.5);
        sum += (rel * half) * s.delta_v.v;
        rel *= UnitQuaternion::from_scaled_axis(s.delta_theta.v);
        dt += s.dt;
    }
    (dt > 0.0 && sum.iter().all(|v| v.is_finite())).then(|| (sum / dt, dt))
}

/// Roll and pitch at a standstill-like first guess: w = g·up, no heading needed.
pub(crate) fn static_level(u: &Vector3<f64>) -> (f64, f64) {
    ((-u.y).atan2(-u.z), u.x.atan2(u.y.hypot(u.z)))
}

/// Roll and pitch from the body mean specific force `u` and its map-frame (east-north-up) counterpart `w`,
/// for heading `heading` (clockwise from north).
pub(crate) fn level(u: &Vector3<f64>, w: &Vector3<f64>, heading: f64) -> (f64, f64) {
    let (s, c) = heading.sin_cos();
    let (f_n, f_e, f_d) = (w.y, w.x, -w.z);
    let h = Vector3::new(c * f_n + s * f_e, -s * f_n + c * f_e, f_d);
    let (guess, _) = static_level(u);
    let r = u.y.hypot(u.z);
    let alpha = u.z.atan2(u.y);
    let spread = (h.y / r).clamp(-1.0, 1.0).acos();
    let roll = [spread - alpha, -spread - alpha].map(wrap).into_iter().fold(f64::NAN, |best, a| {
        if best.is_nan() || wrap(a - guess).abs() < wrap(best - guess).abs() { a } else { best }
    });
    let (sr, cr) = roll.sin_cos();
    let v_z = sr * u.y + cr * u.z;
    let pitch = wrap(h.x.atan2(h.z) - u.x.atan2(v_z));
    (roll, pitch)
}

#[cfg(test)]
mod tests {
    use nalgebra::{Matrix3, Vector3};

    use super::{level, static_level};

    /// R_B^NED = Rz(heading)·Ry(pitch)·Rx(roll) (the Applanix convention), written out independently.
    fn body_to_ned(roll: f64, pitch: f64, heading: f64) -> Matrix3<f64> {
        let (sr, cr) = roll.sin_cos();
        let (sp, cp) = pitch.sin_cos();
        let (sh, ch) = heading.sin_cos();
        let rz = Matrix3::new(ch, -sh, 0.0, sh, ch, 0.0, 0.0, 0.0, 1.0);
        let ry = Matrix3::new(cp, 0.0, sp, 0.0, 1.0, 0.0, -sp, 0.0, cp);
        let rx = Matrix3::new(1.0, 0.0, 0.0, 0.0, cr, -sr, 0.0, sr, cr);
        rz * ry * rx
    }

    #[test]
    fn levelling_inverts_the_specific_force_of_a_tilted_accelerating_body() {
        let g = 9.806_65;
        for (roll, pitch, heading, accel) in [
            (0.02, -0.01, 0.3, [0.0, 0.0, 0.0]),
            (-0.05, 0.04, 2.5, [1.2, -0.8, 0.1]),
            (0.1, 0.08, -1.9, [-2.0, 0.5, -0.3]),
            (0.0, -0.12, 3.1, [0.3, 2.5, 0.0]),
        ] {
            // w in east-north-up; the body sees R_B^NEDᵀ of its NED form.
            let w = Vector3::new(accel[0], accel[1], accel[2] + g);
            let ned = Vector3::new(w.y, w.x, -w.z);
            let u = body_to_ned(roll, pitch, heading).transpose() * ned;
            let (r, p) = level(&u, &w, heading);
            assert!((r - roll).abs() < 1e-9 && (p - pitch).abs() < 1e-9, "{r} {p} vs {roll} {pitch}");
            if accel == [0.0, 0.0, 0.0] {
                let (r, p) = static_level(&u);
                assert!((r - roll).abs() < 1e-9 && (p - pitch).abs() < 1e-9);
            }
        }
    }
}
