//! Small plane-geometry helpers on `[f64; 2]` points: vector arithmetic, polyline length, resampling and
//! point-to-polyline distances.

/// a − b.
pub(crate) fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

/// a + k·d.
pub(crate) fn add_scaled(a: [f64; 2], d: [f64; 2], k: f64) -> [f64; 2] {
    [a[0] + k * d[0], a[1] + k * d[1]]
}

/// Dot product.
pub(crate) fn dot(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

/// z of the cross product (a × b).
pub(crate) fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// Euclidean length.
pub(crate) fn norm(a: [f64; 2]) -> f64 {
    a[0].hypot(a[1])
}

/// Distance between two points.
pub(crate) fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    norm(sub(a, b))
}

/// The unit vector along `a`, or `None` for a (near) zero vector.
pub(crate) fn unit(a: [f64; 2]) -> Option<[f64; 2]> {
    let n = norm(a);
    (n > 1e-12 && n.is_finite()).then(|| [a[0] / n, a[1] / n])
}

/// The left normal of a direction (rotated +90° in a right-handed frame).
pub(crate) fn normal(t: [f64; 2]) -> [f64; 2] {
    [-t[1], t[0]]
}

/// The centroid of `points` and the unit direction of their largest spread (principal axis), with each
/// point's position along it from the centroid.
pub(crate) fn principal_axis(points: &[[f64; 2]]) -> ([f64; 2], [f64; 2], Vec<f64>) {
    let count = points.len() as f64;
    let m = [points.iter().map(|p| p[0]).sum::<f64>() / count, points.iter().map(|p| p[1]).sum::<f64>() / count];
    let (mut cxx, mut cyy, mut cxy) = (0.0, 0.0, 0.0);
    for p in points {
        let d = sub(*p, m);
        (cxx, cyy, cxy) = (cxx + d[0] * d[0], cyy + d[1] * d[1], cxy + d[0] * d[1]);
    }
    let theta = 0.5 * (2.0 * cxy).atan2(cxx - cyy);
    let axis = [theta.cos(), theta.sin()];
    let along = points.iter().map(|p| dot(sub(*p, m), axis)).collect();
    (m, axis, along)
}

/// Total length of a polyline.
pub(crate) fn length(points: &[[f64; 2]]) -> f64 {
    points.windows(2).map(|w| dist(w[0], w[1])).sum()
}

/// A point on a polyline with its unit direction and the length it stands for.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sample {
    pub(crate) p: [f64; 2],
    pub(crate) t: [f64; 2],
    pub(crate) weight: f64,
}

/// Points at the middles of equal intervals no longer than `step` along each segment, each standing for its
/// interval's length: sums over them integrate along the polyline exactly for piecewise-constant properties.
pub(crate) fn midpoints(points: &[[f64; 2]], step: f64) -> Vec<Sample> {
    let mut out = Vec::new();
    for w in points.windows(2) {
        let d = sub(w[1], w[0]);
        let len = norm(d);
        let Some(t) = unit(d) else { continue };
        let n = (len / step).ceil().max(1.0) as usize;
        let part = len / n as f64;
        out.extend((0..n).map(|k| Sample { p: add_scaled(w[0], t, (k as f64 + 0.5) * part), t, weight: part }));
    }
    out
}

/// Points every (at most) `step` along a polyline including both ends, with the local direction.
pub(crate) fn resample(points: &[[f64; 2]], step: f64) -> Vec<Sample> {
    let mut out = Vec::new();
    for (i, w) in points.windows(2).enumerate() {
        let d = sub(w[1], w[0]);
        let len = norm(d);
        let Some(t) = unit(d) else { continue };
        let n = (len / step).ceil().max(1.0) as usize;
        let first = usize::from(i > 0 && !out.is_empty());
        out.extend((first..=n).map(|k| Sample { p: add_scaled(w[0], t, len * k as f64 / n as f64), t, weight: 0.0 }));
    }
    out
}

/// Distance from `p` to segment a–b and the segment's unit direction (None when degenerate).
pub(crate) fn segment_distance(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> (f64, Option<[f64; 2]>) {
    let d = sub(b, a);
    let l2 = dot(d, d);
    if l2 <= 1e-24 {
        return (dist(p, a), None);
    }
    let s = (dot(sub(p, a), d) / l2).clamp(0.0, 1.0);
    (dist(p, add_scaled(a, d, s)), unit(d))
}

/// Angle between two undirected directions, radians in [0, π/2].
pub(crate) fn line_angle(a: [f64; 2], b: [f64; 2]) -> f64 {
    cross(a, b).abs().atan2(dot(a, b).abs())
}

/// The median of a set of values (the project's one median, `plumbline_geo::metrics::median`); 0 for an
/// empty set.
pub(crate) fn median_or_zero(values: &mut [f64]) -> f64 {
    plumbline_geo::metrics::median(values).unwrap_or(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resampling_keeps_the_ends_and_midpoints_integrate_the_length() {
        let line = [[0.0, 0.0], [1.0, 0.0], [1.0, 0.45]];
        let s = resample(&line, 0.2);
        assert_eq!((s[0].p, s[s.len() - 1].p), ([0.0, 0.0], [1.0, 0.45]));
        assert!(s.windows(2).all(|w| dist(w[0].p, w[1].p) <= 0.2 + 1e-12 && dist(w[0].p, w[1].p) > 0.1));
        let total: f64 = midpoints(&line, 0.1).iter().map(|m| m.weight).sum();
        assert!((total - length(&line)).abs() < 1e-12);
        assert_eq!(median_or_zero(&mut [3.0, 1.0, 2.0, 4.0]), 2.5);
        assert_eq!(median_or_zero(&mut []), 0.0);
        assert!((segment_distance([0.5, 0.3], [0.0, 0.0], [1.0, 0.0]).0 - 0.3).abs() < 1e-12);
        assert!((line_angle([1.0, 0.0], [-1.0, 0.01]) - 0.01).abs() < 1e-4);
    }
}
