//! Planar polylines in map coordinates: arc length, points along them and the nearest-point query.

/// A 2D point (easting, northing), metres.
pub type P2 = [f64; 2];

/// Where a point lies relative to a polyline.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Station {
    /// Arc length of the foot point from the start, metres.
    pub s: f64,
    /// Signed distance, positive to the left of the direction of travel, metres.
    pub t: f64,
    /// Unit tangent at the foot point.
    pub tangent: P2,
}

/// Cumulative arc lengths of the vertices.
pub fn cumulative(points: &[P2]) -> Vec<f64> {
    let mut acc = 0.0;
    let mut out = Vec::with_capacity(points.len());
    out.push(0.0);
    for w in points.windows(2) {
        acc += dist(w[0], w[1]);
        out.push(acc);
    }
    out
}

/// Euclidean distance.
pub fn dist(a: P2, b: P2) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// The point at arc length `s` (clamped) and the unit tangent there.
pub fn point_at(points: &[P2], cum: &[f64], s: f64) -> (P2, P2) {
    let last = points.len().saturating_sub(2);
    let i = cum.partition_point(|&c| c <= s).saturating_sub(1).min(last);
    let (a, b) = (points[i], points[i + 1]);
    let len = (cum[i + 1] - cum[i]).max(1e-12);
    let f = ((s - cum[i]) / len).clamp(0.0, 1.0);
    let tan = [(b[0] - a[0]) / len, (b[1] - a[1]) / len];
    ([a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])], tan)
}

/// Foot point on segment `i` of the polyline: (station, squared distance).
pub fn station_on_segment(points: &[P2], cum: &[f64], i: usize, p: P2) -> (Station, f64) {
    let (a, b) = (points[i], points[i + 1]);
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len = (cum[i + 1] - cum[i]).max(1e-12);
    let tan = [dx / len, dy / len];
    let (px, py) = (p[0] - a[0], p[1] - a[1]);
    let along = (px * tan[0] + py * tan[1]).clamp(0.0, len);
    let (fx, fy) = (px - along * tan[0], py - along * tan[1]);
    let d2 = fx * fx + fy * fy;
    // Beyond an end the offset is the distance to the end point, signed by the side.
    let cross = tan[0] * py - tan[1] * px;
    let t = if cross < 0.0 { -d2.sqrt() } else { d2.sqrt() };
    (Station { s: cum[i] + along, t, tangent: tan }, d2)
}

/// The station of the nearest point of the whole polyline.
pub fn nearest(points: &[P2], cum: &[f64], p: P2) -> Station {
    let mut best = (Station { s: 0.0, t: f64::INFINITY, tangent: [1.0, 0.0] }, f64::INFINITY);
    for i in 0..points.len().saturating_sub(1) {
        let cand = station_on_segment(points, cum, i, p);
        if cand.1 < best.1 {
            best = cand;
        }
    }
    best.0
}

/// A quadratic Bézier from `a` to `b` bowed sideways by `bow` metres at its middle, sampled every ~`step` m.
pub fn bowed(a: P2, b: P2, bow: f64, step: f64) -> Vec<P2> {
    let len = dist(a, b);
    let n = ((len / step).ceil() as usize).max(1);
    let normal = [-(b[1] - a[1]) / len, (b[0] - a[0]) / len];
    // The control point sits at twice the sagitta so the curve's middle is `bow` off the chord.
    let c = [(a[0] + b[0]) / 2.0 + 2.0 * bow * normal[0], (a[1] + b[1]) / 2.0 + 2.0 * bow * normal[1]];
    (0..=n)
        .map(|k| {
            let u = k as f64 / n as f64;
            let (w0, w1, w2) = ((1.0 - u) * (1.0 - u), 2.0 * u * (1.0 - u), u * u);
            [w0 * a[0] + w1 * c[0] + w2 * b[0], w0 * a[1] + w1 * c[1] + w2 * b[1]]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn station_sign_is_left_positive_and_arc_length_adds_up() {
        let pts = vec![[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]];
        let cum = cumulative(&pts);
        assert_eq!(cum, vec![0.0, 10.0, 20.0]);
        let st = nearest(&pts, &cum, [4.0, 2.0]);
        assert!((st.s - 4.0).abs() < 1e-12 && (st.t - 2.0).abs() < 1e-12);
        let st = nearest(&pts, &cum, [12.0, 5.0]);
        assert!((st.s - 15.0).abs() < 1e-12 && (st.t + 2.0).abs() < 1e-12);
        let (p, tan) = point_at(&pts, &cum, 15.0);
        assert!((p[0] - 10.0).abs() < 1e-12 && (p[1] - 5.0).abs() < 1e-12 && tan == [0.0, 1.0]);
    }

    #[test]
    fn bowed_curve_has_its_sagitta_at_the_middle() {
        let pts = bowed([0.0, 0.0], [100.0, 0.0], 8.0, 2.0);
        let mid = pts[pts.len() / 2];
        assert!((mid[0] - 50.0).abs() < 1e-9 && (mid[1] - 8.0).abs() < 1e-9, "{mid:?}");
    }
}
