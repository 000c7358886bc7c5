//! The driven path: a route's polyline with every corner rounded by a circular arc (a fillet), parametrised
//! by horizontal arc length `s`, with the street's attributes carried along. Sharp corners between long
//! segments get arcs of the configured turn radius; a densely sampled curve (a world route's waypoints every
//! few metres) keeps its own radius (see `fillet_tangent`).
//!
//! Heading follows the tangent, curvature is 0 on straights and ±1/r on arcs (positive turning left, i.e.
//! counter-clockwise seen from above). Height is linear in `s` on every piece, joining the route's heights
//! at the piece ends, so the grade is constant per piece.

use crate::route::{Canyon, Route, Waypoint};

use super::MotionError;

/// Angles below this (radians) are driven straight through without an arc.
const MIN_TURN: f64 = 1e-6;
/// A fillet uses at most this share of each adjacent segment.
const MAX_SEGMENT_SHARE: f64 = 0.45;
/// A fillet larger than the corner radius may pass at most this far inside its vertex, metres.
const MAX_CORNER_CUT: f64 = 0.5;

/// The state of the path at one arc length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathPoint {
    /// Easting, metres.
    pub east: f64,
    /// Northing, metres.
    pub north: f64,
    /// Road surface height, metres.
    pub height: f64,
    /// Direction of travel, mathematical angle from east, counter-clockwise, radians.
    pub direction: f64,
    /// Signed curvature, 1/m, positive turning left.
    pub curvature: f64,
    /// Height gain per horizontal metre.
    pub grade: f64,
    /// The terrain's rise per metre to the left of travel (`Waypoint::bank`), interpolated between waypoints.
    pub bank: f64,
    /// Smallest speed limit of the route segment, m/s.
    pub speed_limit: f64,
    /// The street's enclosure, interpolated between waypoints.
    pub canyon: Canyon,
}

#[derive(Clone, Copy, Debug)]
enum Shape {
    Line { east: f64, north: f64, direction: f64 },
    Arc { centre_east: f64, centre_north: f64, radius: f64, start_direction: f64, turn: f64 },
}

#[derive(Clone, Copy, Debug)]
struct Piece {
    shape: Shape,
    /// Path arc length at the start and the length of the piece.
    s0: f64,
    len: f64,
    /// Route (polyline) distance at the start and end of the piece.
    d0: f64,
    d1: f64,
}

/// A route with rounded corners, ready to be driven.
#[derive(Clone, Debug)]
pub struct Path {
    waypoints: Vec<Waypoint>,
    /// Polyline distance of every waypoint.
    route_distance: Vec<f64>,
    pieces: Vec<Piece>,
    /// Path arc length of every waypoint (at the middle of its arc).
    waypoint_s: Vec<f64>,
}

impl Path {
    /// Round the corners of `route` with arcs of radius `turn_radius` (smaller where segments are short).
    pub fn new(route: &Route, turn_radius: f64) -> Result<Self, MotionError> {
        let w = &route.waypoints;
        check_route(route)?;
        let n = w.len();
        let seg: Vec<(f64, f64)> = w.windows(2).map(|p| (p[1].east - p[0].east, p[1].north - p[0].north)).collect();
        let len: Vec<f64> = seg.iter().map(|(e, n)| e.hypot(*n)).collect();
        let dir: Vec<f64> = seg.iter().map(|(e, n)| n.atan2(*e)).collect();
        let mut route_distance = vec![0.0; n];
        for i in 1..n {
            route_distance[i] = route_distance[i - 1] + len[i - 1];
        }
        // Tangent distance and turn angle of the fillet at every vertex (none at the ends).
        let mut tangent = vec![0.0; n];
        let mut turn = vec![0.0; n];
        for j in 1..n - 1 {
            let a = wrap(dir[j] - dir[j - 1]);
            if a.abs() > MIN_TURN {
                tangent[j] = fillet_tangent(a.abs(), MAX_SEGMENT_SHARE * len[j - 1].min(len[j]), turn_radius);
                turn[j] = a;
            }
        }
        let mut pieces = Vec::new();
        let mut waypoint_s = vec![0.0; n];
        let mut s = 0.0;
        for i in 0..n - 1 {
            if i > 0 {
                waypoint_s[i] =
                    push_arc(&mut pieces, &mut s, &w[i], dir[i - 1], turn[i], tangent[i], route_distance[i]);
            }
            let (c, sn) = (dir[i].cos(), dir[i].sin());
            let line_len = len[i] - tangent[i] - tangent[i + 1];
            let shape = Shape::Line {
                east: w[i].east + c * tangent[i],
                north: w[i].north + sn * tangent[i],
                direction: dir[i],
            };
            let (d0, d1) = (route_distance[i] + tangent[i], route_distance[i + 1] - tangent[i + 1]);
            pieces.push(Piece { shape, s0: s, len: line_len, d0, d1 });
            s += line_len;
        }
        waypoint_s[n - 1] = s;
        Ok(Self { waypoints: w.clone(), route_distance, pieces, waypoint_s })
    }

    /// Total horizontal length, metres.
    pub fn length(&self) -> f64 {
        self.pieces.last().map_or(0.0, |p| p.s0 + p.len)
    }

    /// Arc length at which the path passes waypoint `index`.
    pub fn waypoint_s(&self, index: usize) -> Option<f64> {
        self.waypoint_s.get(index).copied()
    }

    /// The waypoints of the route.
    pub fn waypoints(&self) -> &[Waypoint] {
        &self.waypoints
    }

    /// The path at arc length `s` (clamped to the path).
    pub fn at(&self, s: f64) -> PathPoint {
        let s = s.clamp(0.0, self.length());
        let k = self.pieces.partition_point(|p| p.s0 + p.len < s).min(self.pieces.len() - 1);
        let p = &self.pieces[k];
        let u = (s - p.s0).clamp(0.0, p.len);
        let w = if p.len > 0.0 { u / p.len } else { 0.0 };
        let d = p.d0 + (p.d1 - p.d0) * w;
        let (h0, h1) = (self.route_height(p.d0), self.route_height(p.d1));
        let grade = if p.len > 0.0 { (h1 - h0) / p.len } else { 0.0 };
        let (east, north, direction, curvature) = shape_at(&p.shape, u);
        let (speed_limit, canyon, bank) = self.attributes(d);
        let height = h0 + (h1 - h0) * w;
        PathPoint { east, north, height, direction, curvature, grade, bank, speed_limit, canyon }
    }

    fn segment_of(&self, d: f64) -> usize {
        self.route_distance.partition_point(|&x| x <= d).clamp(1, self.route_distance.len() - 1) - 1
    }

    fn route_height(&self, d: f64) -> f64 {
        let i = self.segment_of(d);
        let (a, b) = (&self.waypoints[i], &self.waypoints[i + 1]);
        let w = ((d - self.route_distance[i]) / (self.route_distance[i + 1] - self.route_distance[i])).clamp(0.0, 1.0);
        a.ground_height + (b.ground_height - a.ground_height) * w
    }

    fn attributes(&self, d: f64) -> (f64, Canyon, f64) {
        let i = self.segment_of(d);
        let (a, b) = (&self.waypoints[i], &self.waypoints[i + 1]);
        let w = ((d - self.route_distance[i]) / (self.route_distance[i + 1] - self.route_distance[i])).clamp(0.0, 1.0);
        let l = |x: f64, y: f64| x + (y - x) * w;
        let canyon = Canyon {
            street_width: l(a.canyon.street_width, b.canyon.street_width),
            building_height: l(a.canyon.building_height, b.canyon.building_height),
        };
        (a.speed_limit.min(b.speed_limit), canyon, l(a.bank, b.bank))
    }
}

/// Tangent length of the fillet for a turn of `angle` (rad, > 0) with at most `fit` metres of tangent:
/// the largest arc that fits and passes within [`MAX_CORNER_CUT`] of the vertex, but no tighter than
/// `turn_radius` — so a densely sampled curve keeps its own radius and a sharp corner gets `turn_radius`
/// (or less where the segments are too short).
fn fillet_tangent(angle: f64, fit: f64, turn_radius: f64) -> f64 {
    let half_tan = (angle / 2.0).tan();
    let cut_radius = MAX_CORNER_CUT / (1.0 / (angle / 2.0).cos() - 1.0).max(f64::MIN_POSITIVE);
    let radius = (fit / half_tan).min(cut_radius).max(turn_radius);
    (radius * half_tan).min(fit)
}

/// Append the fillet arc at vertex `w`; returns the arc length at its middle (the waypoint's s).
fn push_arc(pieces: &mut Vec<Piece>, s: &mut f64, w: &Waypoint, dir_in: f64, turn: f64, tangent: f64, d: f64) -> f64 {
    if turn == 0.0 || tangent == 0.0 {
        return *s;
    }
    let radius = tangent / (turn.abs() / 2.0).tan();
    let sign = turn.signum();
    let (start_e, start_n) = (w.east - dir_in.cos() * tangent, w.north - dir_in.sin() * tangent);
    // Centre on the inside of the turn: left normal for a left turn.
    let shape = Shape::Arc {
        centre_east: start_e - sign * radius * dir_in.sin(),
        centre_north: start_n + sign * radius * dir_in.cos(),
        radius,
        start_direction: dir_in,
        turn,
    };
    let len = radius * turn.abs();
    pieces.push(Piece { shape, s0: *s, len, d0: d - tangent, d1: d + tangent });
    *s += len;
    *s - len / 2.0
}

/// Position, direction and curvature at distance `u` into a piece.
fn shape_at(shape: &Shape, u: f64) -> (f64, f64, f64, f64) {
    match *shape {
        Shape::Line { east, north, direction } => {
            (east + direction.cos() * u, north + direction.sin() * u, direction, 0.0)
        }
        Shape::Arc { centre_east, centre_north, radius, start_direction, turn } => {
            let sign = turn.signum();
            let theta = start_direction + sign * u / radius;
            let east = centre_east + sign * radius * theta.sin();
            let north = centre_north - sign * radius * theta.cos();
            (east, north, theta, sign / radius)
        }
    }
}

pub(crate) use plumbline_geo::angle::wrap;

fn check_route(route: &Route) -> Result<(), MotionError> {
    let w = &route.waypoints;
    if w.len() < 2 {
        return Err(MotionError::RouteTooShort { waypoints: w.len() });
    }
    for (index, p) in w.iter().enumerate() {
        let fields = [
            ("east", p.east),
            ("north", p.north),
            ("ground_height", p.ground_height),
            ("bank", p.bank),
            ("speed_limit", p.speed_limit),
            ("canyon.street_width", p.canyon.street_width),
            ("canyon.building_height", p.canyon.building_height),
        ];
        for (field, value) in fields {
            if !value.is_finite() {
                return Err(MotionError::Waypoint { index, field, value, expected: "a finite number" });
            }
        }
        if p.speed_limit <= 0.0 {
            return Err(MotionError::Waypoint {
                index,
                field: "speed_limit",
                value: p.speed_limit,
                expected: "> 0 m/s",
            });
        }
        if p.canyon.street_width <= 0.0 || p.canyon.building_height < 0.0 {
            let (field, value) = if p.canyon.street_width <= 0.0 {
                ("canyon.street_width", p.canyon.street_width)
            } else {
                ("canyon.building_height", p.canyon.building_height)
            };
            return Err(MotionError::Waypoint { index, field, value, expected: "a width > 0 and a height >= 0" });
        }
        if index > 0 && (p.east - w[index - 1].east).hypot(p.north - w[index - 1].north) < 0.01 {
            return Err(MotionError::Waypoint {
                index,
                field: "east/north",
                value: p.east,
                expected: "at least 1 cm from the previous waypoint",
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    pub(crate) fn wp(east: f64, north: f64) -> Waypoint {
        Waypoint {
            east,
            north,
            ground_height: 0.0,
            bank: 0.0,
            speed_limit: 13.9,
            junction: false,
            canyon: Canyon::OPEN,
        }
    }

    #[test]
    fn l_turn_is_rounded_tangent_continuous_and_shorter_than_the_polyline() {
        let route = Route { waypoints: vec![wp(0.0, 0.0), wp(100.0, 0.0), wp(100.0, 100.0)] };
        let path = Path::new(&route, 10.0).unwrap();
        // Left turn of 90° with r = 10: saves 2r − πr/2 metres.
        let expected = 200.0 - 20.0 + 10.0 * std::f64::consts::FRAC_PI_2;
        assert!((path.length() - expected).abs() < 1e-9, "{}", path.length());
        let mid = path.at(path.waypoint_s(1).unwrap());
        assert!((mid.curvature - 0.1).abs() < 1e-12);
        assert!((mid.direction - std::f64::consts::FRAC_PI_4).abs() < 1e-9);
        // Distance of the arc middle from the corner: r(1/cos 45° − 1).
        let gap = (mid.east - 100.0).hypot(mid.north);
        assert!((gap - 10.0 * (2f64.sqrt() - 1.0)).abs() < 1e-9, "{gap}");
        // Positions are continuous and move along the heading.
        let mut s = 0.0;
        while s < path.length() - 0.05 {
            let (a, b) = (path.at(s), path.at(s + 0.05));
            let step = (b.east - a.east).hypot(b.north - a.north);
            assert!((step - 0.05).abs() < 1e-4, "s {s}: step {step}");
            let along = ((b.east - a.east) * a.direction.cos() + (b.north - a.north) * a.direction.sin()) / step;
            assert!(along > 0.9999, "s {s}: {along}");
            s += 0.05;
        }
    }

    #[test]
    fn right_turn_has_negative_curvature_and_heights_and_attributes_follow_the_route() {
        let mut route = Route { waypoints: vec![wp(0.0, 0.0), wp(0.0, 50.0), wp(50.0, 50.0)] };
        route.waypoints[1].ground_height = 5.0;
        route.waypoints[1].speed_limit = 8.0;
        route.waypoints[2].canyon = Canyon { street_width: 10.0, building_height: 20.0 };
        let path = Path::new(&route, 5.0).unwrap();
        let mid = path.at(path.waypoint_s(1).unwrap());
        assert!((mid.curvature + 0.2).abs() < 1e-12);
        let first = path.at(20.0);
        assert!((first.grade - 0.1).abs() < 1e-12 && (first.height - 2.0).abs() < 1e-12);
        assert_eq!(first.speed_limit, 8.0);
        let end = path.at(path.length());
        assert!((end.canyon.ratio() - 2.0).abs() < 1e-12 && (end.east - 50.0).abs() < 1e-9);
    }

    #[test]
    fn densely_sampled_curve_keeps_its_radius() {
        // A quarter circle of radius 100 m sampled every ~4 m: the path's curvature stays near 1/100 m,
        // not the 8 m corner radius.
        let n = 40;
        let pts: Vec<Waypoint> = (0..=n)
            .map(|i| {
                let a = std::f64::consts::FRAC_PI_2 * i as f64 / n as f64;
                wp(100.0 * a.sin(), 100.0 - 100.0 * a.cos())
            })
            .collect();
        let path = Path::new(&Route { waypoints: pts }, 8.0).unwrap();
        let arc = std::f64::consts::FRAC_PI_2 * 100.0;
        assert!((path.length() - arc).abs() < 0.1, "{}", path.length());
        let mid = path.at(path.waypoint_s(20).unwrap());
        assert!((1.0 / mid.curvature - 100.0).abs() < 15.0, "radius {}", 1.0 / mid.curvature);
        let max_k = (0..1000).map(|i| path.at(arc * i as f64 / 1000.0).curvature).fold(0.0, f64::max);
        assert!(max_k < 1.0 / 80.0, "{max_k}");
    }

    #[test]
    fn bad_routes_name_the_waypoint_and_field() {
        let err = Path::new(&Route { waypoints: vec![wp(0.0, 0.0)] }, 5.0).unwrap_err();
        assert!(matches!(err, MotionError::RouteTooShort { waypoints: 1 }));
        let mut route = Route { waypoints: vec![wp(0.0, 0.0), wp(10.0, 0.0), wp(10.0, 0.0)] };
        let err = Path::new(&route, 5.0).unwrap_err();
        assert!(err.to_string().contains("waypoint 2"), "{err}");
        route.waypoints[2] = wp(20.0, 0.0);
        route.waypoints[1].speed_limit = f64::NAN;
        let err = Path::new(&route, 5.0).unwrap_err();
        assert!(err.to_string().contains("waypoint 1") && err.to_string().contains("speed_limit"), "{err}");
    }
}
