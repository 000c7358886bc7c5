//! The local ground height of a frame: the lowest clear peak of the heights of the points well below the
//! sensor (a parked car's roof can hold more points than the visible road, but lies above it), refined by
//! the mean around the peak.

use super::DetectError;
use crate::points::FramePoints;

/// Histogram bin, metres.
const BIN_M: f64 = 0.05;
/// Points must lie this far below the sensor to count, metres.
const BELOW_M: f64 = 0.5;
/// Half-width of the window around the mode that is averaged, metres.
const WINDOW_M: f64 = 0.15;
/// A peak must hold this share of the highest bin.
const PEAK_SHARE: u32 = 5;
/// Fewest points below the sensor.
const MIN_POINTS: usize = 30;

/// The ground height near the sensor.
pub(super) fn estimate(frame: &FramePoints, max_range_m: f64) -> Result<f64, DetectError> {
    let o = frame.origin;
    let heights: Vec<f64> = frame
        .points
        .iter()
        .filter(|p| {
            let d = p.position - o;
            d.z < -BELOW_M && d.xy().norm() <= max_range_m
        })
        .map(|p| p.position.z)
        .collect();
    if heights.len() < MIN_POINTS {
        return Err(DetectError::NoGround { points: heights.len() });
    }
    let lowest = heights.iter().copied().fold(f64::INFINITY, f64::min);
    let bins = (((o.z - BELOW_M - lowest) / BIN_M).ceil() as usize + 1).min(100_000);
    let mut counts = vec![0u32; bins];
    for h in &heights {
        counts[(((h - lowest) / BIN_M) as usize).min(bins - 1)] += 1;
    }
    // Smooth over three bins so that noise does not split the mode.
    let smoothed = |i: usize| counts[i.saturating_sub(1)..(i + 2).min(bins)].iter().sum::<u32>();
    let top = (0..bins).map(smoothed).max().unwrap_or(0);
    let is_peak = |i: usize| {
        let v = smoothed(i);
        PEAK_SHARE * v >= top && v >= smoothed(i.saturating_sub(1)) && (i + 1 >= bins || v >= smoothed(i + 1))
    };
    let mode = (0..bins).find(|&i| is_peak(i)).unwrap_or(0);
    let centre = lowest + (mode as f64 + 0.5) * BIN_M;
    let near: Vec<f64> = heights.into_iter().filter(|h| (h - centre).abs() <= WINDOW_M).collect();
    Ok(if near.is_empty() { centre } else { near.iter().sum::<f64>() / near.len() as f64 })
}
