//! Trajectories: time-sorted vehicle poses in the mapping frame with standard deviations, their validation
//! and interpolation at arbitrary times (position linear or cubic Hermite, attitude slerp).

use serde::{Deserialize, Serialize};

use crate::attitude::Attitude;
use crate::frames::{Map, MapFromBody, Point3, Vec3};

/// One-sigma standard deviations of a pose: metres and radians.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct PoseStd {
    /// Easting, metres.
    pub east: f64,
    /// Northing, metres.
    pub north: f64,
    /// Height, metres.
    pub height: f64,
    /// Roll, radians.
    pub roll: f64,
    /// Pitch, radians.
    pub pitch: f64,
    /// Heading, radians.
    pub heading: f64,
}

impl PoseStd {
    fn fields(&self) -> [(&'static str, f64); 6] {
        [
            ("std_east", self.east),
            ("std_north", self.north),
            ("std_height", self.height),
            ("std_roll", self.roll),
            ("std_pitch", self.pitch),
            ("std_heading", self.heading),
        ]
    }

    fn lerp(&self, other: &Self, w: f64) -> Self {
        let l = |a: f64, b: f64| a + (b - a) * w;
        Self {
            east: l(self.east, other.east),
            north: l(self.north, other.north),
            height: l(self.height, other.height),
            roll: l(self.roll, other.roll),
            pitch: l(self.pitch, other.pitch),
            heading: l(self.heading, other.heading),
        }
    }
}

/// One epoch of a trajectory: the vehicle body pose in the mapping frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrajectoryRecord {
    /// Time, seconds (GPS seconds of week or any continuous time scale the campaign uses).
    pub time: f64,
    /// Position of the body (IMU) origin: easting, northing, height.
    pub position: Point3<Map>,
    /// Attitude of the body frame (canonical Applanix convention).
    pub attitude: Attitude,
    /// Standard deviations when the source gives them.
    pub std: Option<PoseStd>,
}

impl TrajectoryRecord {
    /// The body-to-map pose.
    pub fn pose(&self) -> MapFromBody {
        MapFromBody::new(self.attitude.to_rotation(), self.position)
    }
}

/// Limits applied by [`Trajectory::new`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ValidationLimits {
    /// Largest plausible speed between consecutive records, m/s (default 70 m/s ≈ 250 km/h).
    pub max_speed: f64,
}

impl Default for ValidationLimits {
    fn default() -> Self {
        Self { max_speed: 70.0 }
    }
}

/// A defect found while validating a trajectory, naming the record (0-based) and the field.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TrajectoryError {
    /// The trajectory has no records.
    #[error("trajectory is empty")]
    Empty,
    /// A value is NaN or infinite.
    #[error("record {index} (time {time}): field `{field}` is not finite ({value})")]
    NotFinite { index: usize, time: f64, field: &'static str, value: f64 },
    /// A standard deviation is negative.
    #[error("record {index} (time {time}): field `{field}` is negative ({value})")]
    NegativeStd { index: usize, time: f64, field: &'static str, value: f64 },
    /// Time does not strictly increase.
    #[error("record {index}: time {time} does not increase after record {} (time {previous})", index - 1)]
    TimeNotIncreasing { index: usize, time: f64, previous: f64 },
    /// The vehicle would have moved implausibly fast.
    #[error(
        "record {index} (time {time}): implied speed {speed:.1} m/s since record {} exceeds the limit of {limit} m/s",
        index - 1
    )]
    ImplausibleSpeed { index: usize, time: f64, speed: f64, limit: f64 },
}

/// Errors of trajectory queries.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum QueryError {
    /// The requested time lies outside the trajectory.
    #[error("time {time} is outside the trajectory's span [{start}, {end}]")]
    OutOfRange { time: f64, start: f64, end: f64 },
    /// The requested time is not finite.
    #[error("time {0} is not finite")]
    NotFinite(f64),
}

/// How positions are interpolated between records.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum PositionInterpolation {
    /// Straight line between the two neighbouring records.
    Linear,
    /// Cubic Hermite with velocities from the neighbouring records (non-uniform Catmull–Rom).
    #[default]
    Cubic,
}

/// A validated trajectory: non-empty, strictly increasing time, finite values, plausible speeds.
#[derive(Clone, Debug, PartialEq)]
pub struct Trajectory {
    records: Vec<TrajectoryRecord>,
}

impl Trajectory {
    /// Validate and wrap records. The first defect found is returned; see [`Trajectory::problems`] for all.
    pub fn new(records: Vec<TrajectoryRecord>, limits: &ValidationLimits) -> Result<Self, TrajectoryError> {
        match Self::problems(&records, limits).into_iter().next() {
            Some(e) => Err(e),
            None => Ok(Self { records }),
        }
    }

    /// Every defect of a record list, in record order.
    pub fn problems(records: &[TrajectoryRecord], limits: &ValidationLimits) -> Vec<TrajectoryError> {
        if records.is_empty() {
            return vec![TrajectoryError::Empty];
        }
        let mut out = Vec::new();
        for (index, r) in records.iter().enumerate() {
            check_record(index, r, &mut out);
        }
        for (index, pair) in records.windows(2).enumerate() {
            check_step(index + 1, &pair[0], &pair[1], limits, &mut out);
        }
        out.sort_by_key(problem_index);
        out
    }

    /// The records.
    pub fn records(&self) -> &[TrajectoryRecord] {
        &self.records
    }

    /// Consume into the records.
    pub fn into_records(self) -> Vec<TrajectoryRecord> {
        self.records
    }

    /// Number of records (never zero).
    pub fn len(&self) -> usize {
        self.records.len()
    }

    /// Always false: a trajectory has at least one record.
    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }

    /// First and last time.
    pub fn span(&self) -> (f64, f64) {
        let first = self.records.first().map_or(f64::NAN, |r| r.time);
        let last = self.records.last().map_or(f64::NAN, |r| r.time);
        (first, last)
    }

    /// The pose at time `t`: position by `method`, attitude by slerp, standard deviations linearly.
    pub fn interpolate(&self, t: f64, method: PositionInterpolation) -> Result<TrajectoryRecord, QueryError> {
        let i = self.segment(t)?;
        let (a, b) = (&self.records[i], &self.records[(i + 1).min(self.records.len() - 1)]);
        if a.time == t || i + 1 == self.records.len() {
            return Ok(*a);
        }
        let w = (t - a.time) / (b.time - a.time);
        let position = match method {
            PositionInterpolation::Linear => a.position + (b.position - a.position) * w,
            PositionInterpolation::Cubic => self.hermite(i, t),
        };
        let rotation = a.attitude.to_rotation().slerp(&b.attitude.to_rotation(), w);
        let std = match (a.std, b.std) {
            (Some(sa), Some(sb)) => Some(sa.lerp(&sb, w)),
            _ => None,
        };
        Ok(TrajectoryRecord { time: t, position, attitude: Attitude::from_rotation(&rotation), std })
    }

    /// Velocity (m/s, mapping frame) at record `i` by central differences (one-sided at the ends).
    pub fn velocity_at(&self, i: usize) -> Vec3<Map> {
        let n = self.records.len();
        if n < 2 {
            return Vec3::zeros();
        }
        let (lo, hi) = (i.saturating_sub(1), (i + 1).min(n - 1));
        let (a, b) = (&self.records[lo], &self.records[hi]);
        (b.position - a.position) * (1.0 / (b.time - a.time))
    }

    /// Velocity (m/s, mapping frame) at time `t`: the linearly interpolated positions `half_span` seconds
    /// either side differenced, one-sided where that passes an end of the trajectory. `None` when `t` lies
    /// outside the trajectory, `half_span` is not positive, or no time separates the two positions (a
    /// trajectory of one record).
    pub fn velocity(&self, t: f64, half_span: f64) -> Option<Vec3<Map>> {
        if half_span.is_nan() || half_span <= 0.0 {
            return None;
        }
        self.segment(t).ok()?;
        let (start, end) = self.span();
        let (t0, t1) = ((t - half_span).max(start), (t + half_span).min(end));
        let at = |time: f64| self.interpolate(time, PositionInterpolation::Linear).ok().map(|r| r.position);
        let (a, b) = (at(t0)?, at(t1)?);
        (t1 > t0).then(|| (b - a) * (1.0 / (t1 - t0)))
    }

    /// Index `i` with `records[i].time <= t < records[i+1].time` (or the last index when `t` is the end).
    fn segment(&self, t: f64) -> Result<usize, QueryError> {
        if !t.is_finite() {
            return Err(QueryError::NotFinite(t));
        }
        let (start, end) = self.span();
        if t < start || t > end {
            return Err(QueryError::OutOfRange { time: t, start, end });
        }
        let upper = self.records.partition_point(|r| r.time <= t);
        Ok(upper.saturating_sub(1))
    }

    /// Cubic Hermite position on segment `i` with Catmull–Rom tangents for non-uniform spacing.
    fn hermite(&self, i: usize, t: f64) -> Point3<Map> {
        let (a, b) = (&self.records[i], &self.records[i + 1]);
        let h = b.time - a.time;
        let s = (t - a.time) / h;
        let (va, vb) = (self.velocity_at(i), self.velocity_at(i + 1));
        let (s2, s3) = (s * s, s * s * s);
        let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
        let h10 = s3 - 2.0 * s2 + s;
        let h01 = -2.0 * s3 + 3.0 * s2;
        let h11 = s3 - s2;
        Point3::from_vector(a.position.p * h00 + va.v * (h10 * h) + b.position.p * h01 + vb.v * (h11 * h))
    }
}

fn problem_index(e: &TrajectoryError) -> usize {
    match e {
        TrajectoryError::Empty => 0,
        TrajectoryError::NotFinite { index, .. }
        | TrajectoryError::NegativeStd { index, .. }
        | TrajectoryError::TimeNotIncreasing { index, .. }
        | TrajectoryError::ImplausibleSpeed { index, .. } => *index,
    }
}

fn check_record(index: usize, r: &TrajectoryRecord, out: &mut Vec<TrajectoryError>) {
    let time = r.time;
    let mut fields = vec![
        ("time", r.time),
        ("easting", r.position.x()),
        ("northing", r.position.y()),
        ("height", r.position.z()),
        ("roll", r.attitude.roll),
        ("pitch", r.attitude.pitch),
        ("heading", r.attitude.heading),
    ];
    if let Some(std) = &r.std {
        fields.extend(std.fields());
    }
    for (field, value) in fields {
        if !value.is_finite() {
            out.push(TrajectoryError::NotFinite { index, time, field, value });
        } else if field.starts_with("std_") && value < 0.0 {
            out.push(TrajectoryError::NegativeStd { index, time, field, value });
        }
    }
}

fn check_step(
    index: usize,
    a: &TrajectoryRecord,
    b: &TrajectoryRecord,
    limits: &ValidationLimits,
    out: &mut Vec<TrajectoryError>,
) {
    if !(a.time.is_finite() && b.time.is_finite()) {
        return;
    }
    if b.time <= a.time {
        out.push(TrajectoryError::TimeNotIncreasing { index, time: b.time, previous: a.time });
        return;
    }
    if !(a.position.is_finite() && b.position.is_finite()) {
        return;
    }
    let speed = (b.position - a.position).norm() / (b.time - a.time);
    if speed > limits.max_speed {
        out.push(TrajectoryError::ImplausibleSpeed { index, time: b.time, speed, limit: limits.max_speed });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    pub(crate) fn rec(time: f64, e: f64, n: f64, h: f64, heading_deg: f64) -> TrajectoryRecord {
        TrajectoryRecord {
            time,
            position: Point3::new(e, n, h),
            attitude: Attitude::from_degrees(0.0, 0.0, heading_deg),
            std: None,
        }
    }

    fn limits() -> ValidationLimits {
        ValidationLimits::default()
    }

    #[test]
    fn validation_names_the_record_and_field() {
        let mut records =
            vec![rec(0.0, 0.0, 0.0, 0.0, 0.0), rec(1.0, 1.0, 0.0, 0.0, 0.0), rec(2.0, 2.0, 0.0, 0.0, 0.0)];
        records[1].attitude.pitch = f64::NAN;
        let err = Trajectory::new(records.clone(), &limits()).unwrap_err();
        assert_eq!(err.to_string(), "record 1 (time 1): field `pitch` is not finite (NaN)");

        records[1].attitude.pitch = 0.0;
        records[2].time = 1.0;
        let err = Trajectory::new(records.clone(), &limits()).unwrap_err();
        assert_eq!(err, TrajectoryError::TimeNotIncreasing { index: 2, time: 1.0, previous: 1.0 });

        records[2].time = 2.0;
        records[2].position = Point3::new(500.0, 0.0, 0.0);
        let err = Trajectory::new(records, &limits()).unwrap_err();
        assert!(matches!(err, TrajectoryError::ImplausibleSpeed { index: 2, .. }), "{err}");
        assert!(matches!(Trajectory::new(vec![], &limits()), Err(TrajectoryError::Empty)));
    }

    #[test]
    fn problems_lists_every_defect() {
        let mut records =
            vec![rec(0.0, 0.0, 0.0, 0.0, 0.0), rec(1.0, 1.0, 0.0, 0.0, 0.0), rec(0.5, 2.0, 0.0, 0.0, 0.0)];
        records[0].std = Some(PoseStd { east: -0.1, north: 0.1, height: 0.1, roll: 0.0, pitch: 0.0, heading: 0.0 });
        records[1].position = Point3::new(f64::INFINITY, 0.0, 0.0);
        let problems = Trajectory::problems(&records, &limits());
        assert_eq!(problems.len(), 3, "{problems:?}");
    }

    #[test]
    fn linear_and_cubic_interpolation_are_exact_on_their_own_curves() {
        // Uniform motion: both methods exact. Quadratic motion: cubic Hermite with Catmull–Rom tangents exact
        // for a parabola on uniform spacing at interior segments.
        let line: Vec<_> = (0..6).map(|i| rec(i as f64, 3.0 * i as f64, -2.0 * i as f64, 1.0, 0.0)).collect();
        let t = Trajectory::new(line, &limits()).unwrap();
        for method in [PositionInterpolation::Linear, PositionInterpolation::Cubic] {
            let p = t.interpolate(2.25, method).unwrap().position;
            assert!((p - Point3::new(6.75, -4.5, 1.0)).norm() < 1e-12);
        }
        let para: Vec<_> = (0..6).map(|i| rec(i as f64, (i * i) as f64, 0.0, 0.0, 0.0)).collect();
        let t = Trajectory::new(para, &limits()).unwrap();
        let cubic = t.interpolate(2.5, PositionInterpolation::Cubic).unwrap().position;
        let linear = t.interpolate(2.5, PositionInterpolation::Linear).unwrap().position;
        assert!((cubic.x() - 6.25).abs() < 1e-12, "{cubic:?}");
        assert!((linear.x() - 6.5).abs() < 1e-12);
    }

    #[test]
    fn velocity_is_the_central_difference_and_one_sided_at_the_ends() {
        // 10 Hz records of x = t² (m): velocity 2t inside, the one-sided slope within 50 ms of an end.
        let recs: Vec<_> = (0..=20).map(|i| f64::from(i) * 0.1).map(|t| rec(t, t * t, 0.5 * t, 0.0, 0.0)).collect();
        let t = Trajectory::new(recs, &limits()).unwrap();
        let v = t.velocity(1.0, 0.05).unwrap();
        assert!((v.x() - 2.0).abs() < 1e-9 && (v.y() - 0.5).abs() < 1e-9, "{v:?}");
        // At the start: (x(0.05) − x(0)) / 0.05 on the first segment's chord, slope 0.1.
        let v0 = t.velocity(0.0, 0.05).unwrap();
        assert!((v0.x() - 0.1).abs() < 1e-9, "{v0:?}");
        let v_end = t.velocity(2.0, 0.05).unwrap();
        assert!((v_end.x() - 3.9).abs() < 1e-9, "{v_end:?}");
        assert_eq!(t.velocity(2.5, 0.05), None);
        assert_eq!(t.velocity(1.0, 0.0), None);
        let one = Trajectory::new(vec![rec(0.0, 0.0, 0.0, 0.0, 0.0)], &limits()).unwrap();
        assert_eq!(one.velocity(0.0, 0.05), None);
    }

    #[test]
    fn attitude_interpolation_takes_the_short_way_across_north() {
        let t =
            Trajectory::new(vec![rec(0.0, 0.0, 0.0, 0.0, 350.0), rec(1.0, 0.0, 1.0, 0.0, 10.0)], &limits()).unwrap();
        let mid = t.interpolate(0.5, PositionInterpolation::Linear).unwrap();
        let h = mid.attitude.heading.to_degrees();
        assert!(h.abs() < 1e-9 || (h - 360.0).abs() < 1e-9, "{h}");
        let quarter = t.interpolate(0.25, PositionInterpolation::Linear).unwrap();
        assert!((quarter.attitude.heading.to_degrees() - 355.0).abs() < 1e-9);
    }

    #[test]
    fn interpolation_outside_the_span_is_an_error() {
        let t = Trajectory::new(vec![rec(0.0, 0.0, 0.0, 0.0, 0.0), rec(1.0, 1.0, 0.0, 0.0, 0.0)], &limits()).unwrap();
        assert!(matches!(t.interpolate(1.5, PositionInterpolation::Cubic), Err(QueryError::OutOfRange { .. })));
        assert!(matches!(t.interpolate(f64::NAN, PositionInterpolation::Cubic), Err(QueryError::NotFinite(_))));
        assert_eq!(t.interpolate(1.0, PositionInterpolation::Cubic).unwrap().time, 1.0);
    }
}
