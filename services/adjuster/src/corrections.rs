//! `corrections.csv`: one row per corrected record with the correction applied to it and the posterior σ
//! (the columns of `plumbline adjust`'s file).

use std::fmt::Write as _;

use nalgebra::Rotation3;
use plumbline_geo::Trajectory;

/// Header of `corrections.csv`.
pub const CORRECTIONS_HEADER: &str = "time_s,d_east_m,d_north_m,d_up_m,d_rot_east_rad,d_rot_north_rad,d_rot_up_rad,\
    std_east_m,std_north_m,std_up_m,std_roll_rad,std_pitch_rad,std_heading_rad\n";

/// One row per record of `corrected` (record k corrects record k of `dg`): the correction as applied,
/// δp = p' − p and δθ = Log(R' Rᵀ) (R' = Exp(δθ) R, δθ in the map frame) — inside a standstill the pose held
/// at rest, elsewhere the adjustment's interpolated node correction — and the posterior σ of the corrected
/// pose (empty where it has none).
pub fn corrections_csv(dg: &Trajectory, corrected: &Trajectory) -> Vec<u8> {
    let mut s = String::from(CORRECTIONS_HEADER);
    for (a, b) in dg.records().iter().zip(corrected.records()) {
        let dp = b.position - a.position;
        let (ra, rb) = (a.attitude.to_rotation().matrix(), b.attitude.to_rotation().matrix());
        let dtheta = Rotation3::from_matrix_unchecked(rb * ra.transpose()).scaled_axis();
        let _ = write!(s, "{},{},{},{},{},{},{}", b.time, dp.x(), dp.y(), dp.z(), dtheta.x, dtheta.y, dtheta.z);
        match b.std {
            Some(p) => {
                let _ = write!(s, ",{},{},{},{},{},{}", p.east, p.north, p.height, p.roll, p.pitch, p.heading);
            }
            None => s.push_str(",,,,,,"),
        }
        s.push('\n');
    }
    s.into_bytes()
}
