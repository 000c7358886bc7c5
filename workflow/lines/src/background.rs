//! The local background of an ortho patch and the robust noise scale of the image minus it: a box mean over
//! valid pixels (about 1.5 m), computed on blocks of pixels with sliding sums and interpolated bilinearly,
//! repeated twice without the pixels found bright so paint does not lift its own background.

/// Image minus local background, and the robust σ of that difference over valid pixels. The background is
/// the box mean of blocks of pixels (a 17-block window at the default settings), interpolated bilinearly.
pub(crate) fn background_difference(
    image: &[f32],
    valid: &[bool],
    width: usize,
    height: usize,
    half: usize,
    min_contrast: f64,
) -> (Vec<f32>, f64) {
    let blocks = Blocks::new(width, height, (half / 8).max(1));
    let block_half = ((half as f64 / blocks.size as f64).round() as usize).max(1);
    let (first, _) = blocks.box_mean(image, valid, block_half);
    let mut diff = blocks.subtract(image, &first);
    let mut keep = valid.to_vec();
    let min_count = ((2 * half + 1).pow(2) / 10) as f32;
    // Two more passes without the bright pixels, so stripes (up to half the window wide) do not lift their
    // own background; the second pass catches worn paint the inflated σ of the first let through.
    for _ in 0..2 {
        let exclude = (2.5 * robust_sigma(&diff, valid)).max(0.5 * min_contrast) as f32;
        keep.iter_mut().zip(&diff).for_each(|(k, &d)| *k = *k && d <= exclude);
        let (mean, count) = blocks.box_mean(image, &keep, block_half);
        let background: Vec<f32> =
            mean.iter().zip(&count).zip(&first).map(|((&m, &c), &f)| if c >= min_count { m } else { f }).collect();
        diff = blocks.subtract(image, &background);
    }
    let noise = robust_sigma(&diff, valid);
    (diff, noise)
}

/// Image minus its grey-level opening (the white top-hat), and the robust σ of that difference over valid
/// pixels, the difference's median over valid pixels taken off. The opening by a square of `2·half + 1`
/// pixels (erosion then dilation, each a sliding minimum / maximum along the rows, then down the columns)
/// keeps every bright area the square fits in — a car's body, a pavement, the lit side of a shadow's edge —
/// and removes what is narrower: paint stands out of it while the edges of wider areas do not, unlike a box
/// mean, which lifts the road beside a bright car or a shadow's edge as much as the paint. The noise's minima
/// sink the opening by about two σ everywhere alike, which the median taken off removes. (It is not taken
/// on a smoothed image: smoothing fills a dark gap of a pixel or two between paint and a car, and the
/// opening would then take the paint for part of the car.) Invalid pixels take part in neither step; a pixel
/// whose square holds none keeps a difference of zero.
pub(crate) fn opening_difference(
    image: &[f32],
    valid: &[bool],
    width: usize,
    height: usize,
    half: usize,
) -> (Vec<f32>, f64) {
    let mut level: Vec<f32> = image.iter().zip(valid).map(|(&v, &ok)| if ok { v } else { f32::INFINITY }).collect();
    slide_2d(&mut level, width, height, half, f32::min);
    level.iter_mut().for_each(|v| {
        if !v.is_finite() {
            *v = f32::NEG_INFINITY;
        }
    });
    slide_2d(&mut level, width, height, half, f32::max);
    let mut diff: Vec<f32> = image
        .iter()
        .zip(&level)
        .zip(valid)
        .map(|((&x, &o), &ok)| if ok && o.is_finite() { x - o } else { 0.0 })
        .collect();
    let median = median_of(&diff, valid);
    diff.iter_mut().zip(valid).for_each(|(d, &ok)| *d = if ok { *d - median } else { 0.0 });
    let noise = robust_sigma(&diff, valid);
    (diff, noise)
}

/// `pick` (min or max) over the square of ±`half` pixels around every pixel, in place: along the rows,
/// then down the columns (a square's extreme is separable).
fn slide_2d(values: &mut [f32], width: usize, height: usize, half: usize, pick: fn(f32, f32) -> f32) {
    let mut line = Vec::with_capacity(width.max(height));
    let mut out = Vec::with_capacity(width.max(height));
    for r in 0..height {
        line.clear();
        line.extend_from_slice(&values[r * width..(r + 1) * width]);
        slide_1d(&line, half, pick, &mut out);
        values[r * width..(r + 1) * width].copy_from_slice(&out);
    }
    for c in 0..width {
        line.clear();
        line.extend((0..height).map(|r| values[r * width + c]));
        slide_1d(&line, half, pick, &mut out);
        for (r, &v) in out.iter().enumerate() {
            values[r * width + c] = v;
        }
    }
}

/// `pick` over the window of ±`half` around every element of `line` (clipped at the ends), by van Herk and
/// Gil-Werman's blocks of `2·half + 1`: the running extreme from each block's start and from its end.
fn slide_1d(line: &[f32], half: usize, pick: fn(f32, f32) -> f32, out: &mut Vec<f32>) {
    let n = line.len();
    out.clear();
    if n == 0 {
        return;
    }
    let k = 2 * half + 1;
    let mut forward = line.to_vec();
    let mut backward = line.to_vec();
    for i in 1..n {
        if i % k != 0 {
            forward[i] = pick(forward[i - 1], line[i]);
        }
    }
    for i in (0..n - 1).rev() {
        if (i + 1) % k != 0 {
            backward[i] = pick(backward[i + 1], line[i]);
        }
    }
    // The window [a, b] = [i − half, i + half] clipped to the line spans at most two blocks: the backward run
    // from a and the forward run to b cover it exactly. Within one block, a is the block's start (the forward
    // run to b) or b the line's end (the backward run from a).
    out.extend((0..n).map(|i| {
        let (a, b) = (i.saturating_sub(half), (i + half).min(n - 1));
        match (a / k == b / k, a % k == 0) {
            (false, _) => pick(backward[a], forward[b]),
            (true, true) => forward[b],
            (true, false) => backward[a],
        }
    }));
}

/// Median of the valid values (at most ~60 000 of them, evenly strided), 0 when none is valid.
fn median_of(values: &[f32], valid: &[bool]) -> f32 {
    median_in(&mut valid_sample(values, valid))
}

/// At most ~60 000 of the valid values, evenly strided.
fn valid_sample(values: &[f32], valid: &[bool]) -> Vec<f32> {
    let stride = (values.len() / 60_000).max(1);
    values.iter().zip(valid).step_by(stride).filter(|p| *p.1).map(|p| *p.0).collect()
}

/// Median of `v` (reordered), 0 when empty.
fn median_in(v: &mut [f32]) -> f32 {
    if v.is_empty() {
        return 0.0;
    }
    let mid = v.len() / 2;
    *v.select_nth_unstable_by(mid, f32::total_cmp).1
}

/// The image cut into square blocks of `size` pixels (the last row and column of blocks may be partial).
#[derive(Clone, Copy, Debug)]
struct Blocks {
    width: usize,
    height: usize,
    size: usize,
    cols: usize,
    rows: usize,
}

impl Blocks {
    fn new(width: usize, height: usize, size: usize) -> Self {
        Self { width, height, size, cols: width.div_ceil(size), rows: height.div_ceil(size) }
    }

    /// Per block, the mean over the (2·half + 1)² blocks around it of the pixels where `used` holds, and
    /// their count.
    fn box_mean(&self, values: &[f32], used: &[bool], half: usize) -> (Vec<f32>, Vec<f32>) {
        let mut sums = vec![0.0f32; self.cols * self.rows];
        let mut counts = vec![0.0f32; self.cols * self.rows];
        for r in 0..self.height {
            let base = (r / self.size) * self.cols;
            let line = r * self.width..(r + 1) * self.width;
            let chunks = values[line.clone()].chunks(self.size).zip(used[line].chunks(self.size));
            for (k, (v, u)) in chunks.enumerate() {
                let (sum, n) = v.iter().zip(u).fold((0.0, 0.0), |(s, n), (&v, &u)| {
                    let w = f32::from(u8::from(u));
                    (s + w * v, n + w)
                });
                sums[base + k] += sum;
                counts[base + k] += n;
            }
        }
        window_mean(&sums, &counts, self.cols, self.rows, half)
    }

    /// The image minus the block values interpolated bilinearly between block centres.
    fn subtract(&self, image: &[f32], block: &[f32]) -> Vec<f32> {
        let weights = |n: usize, blocks: usize| -> Vec<(usize, usize, f32)> {
            (0..n)
                .map(|i| {
                    let x = ((i as f32 + 0.5) / self.size as f32 - 0.5).clamp(0.0, (blocks - 1) as f32);
                    let i0 = (x.floor() as usize).min(blocks - 1);
                    (i0, (i0 + 1).min(blocks - 1), x - i0 as f32)
                })
                .collect()
        };
        let (wx, wy) = (weights(self.width, self.cols), weights(self.height, self.rows));
        let mut out = vec![0.0f32; image.len()];
        let mut between = vec![0.0f32; self.cols];
        for (r, &(r0, r1, fy)) in wy.iter().enumerate() {
            let (top, bottom) =
                (&block[r0 * self.cols..(r0 + 1) * self.cols], &block[r1 * self.cols..(r1 + 1) * self.cols]);
            between.iter_mut().zip(top.iter().zip(bottom)).for_each(|(m, (&t, &b))| *m = t + fy * (b - t));
            let line = r * self.width..(r + 1) * self.width;
            for ((o, &x), &(c0, c1, fx)) in out[line.clone()].iter_mut().zip(&image[line]).zip(&wx) {
                let (a, b) = (between[c0], between[c1]);
                *o = x - (a + fx * (b - a));
            }
        }
        out
    }
}

/// Mean of `sums` over the (2·half + 1)² window (clipped at the border) weighted by `counts`, and the
/// window's count: a sliding sum along each row, then one down the columns.
fn window_mean(sums: &[f32], counts: &[f32], width: usize, height: usize, half: usize) -> (Vec<f32>, Vec<f32>) {
    let (row_sum, row_cnt) = (slide_rows(sums, width, half), slide_rows(counts, width, half));
    let mut mean = vec![0.0f32; width * height];
    let mut count = vec![0.0f32; width * height];
    let (mut acc, mut n) = (vec![0.0f32; width], vec![0.0f32; width]);
    let row = |r: usize| r * width..(r + 1) * width;
    let add = |acc: &mut [f32], src: &[f32]| acc.iter_mut().zip(src).for_each(|(a, &x)| *a += x);
    let remove = |acc: &mut [f32], src: &[f32]| acc.iter_mut().zip(src).for_each(|(a, &x)| *a -= x);
    for r in 0..half.min(height) {
        add(&mut acc, &row_sum[row(r)]);
        add(&mut n, &row_cnt[row(r)]);
    }
    for r in 0..height {
        if r + half < height {
            add(&mut acc, &row_sum[row(r + half)]);
            add(&mut n, &row_cnt[row(r + half)]);
        }
        if let Some(gone) = r.checked_sub(half + 1) {
            remove(&mut acc, &row_sum[row(gone)]);
            remove(&mut n, &row_cnt[row(gone)]);
        }
        for ((m, k), (&a, &c)) in mean[row(r)].iter_mut().zip(&mut count[row(r)]).zip(acc.iter().zip(&n)) {
            let c = c.round().max(0.0);
            (*m, *k) = (if c > 0.0 { a / c } else { 0.0 }, c);
        }
    }
    (mean, count)
}

/// Sliding sums over ±`half` columns along every row.
fn slide_rows(values: &[f32], width: usize, half: usize) -> Vec<f32> {
    let mut out = vec![0.0f32; values.len()];
    for (v, o) in values.chunks_exact(width).zip(out.chunks_exact_mut(width)) {
        let mut acc: f32 = v[..half.min(width)].iter().sum();
        for c in 0..width {
            if c + half < width {
                acc += v[c + half];
            }
            if let Some(gone) = c.checked_sub(half + 1) {
                acc -= v[gone];
            }
            o[c] = acc;
        }
    }
    out
}

/// 1.4826 · median absolute deviation of the valid values (at most ~60 000 of them, evenly strided).
fn robust_sigma(values: &[f32], valid: &[bool]) -> f64 {
    let mut v = valid_sample(values, valid);
    let med = median_in(&mut v);
    v.iter_mut().for_each(|x| *x = (*x - med).abs());
    f64::from(median_in(&mut v)) * 1.4826
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sliding_extremes_equal_the_brute_force_ones_and_the_opening_keeps_wide_areas() {
        let line: Vec<f32> = (0..23).map(|i| ((i * 37) % 11) as f32).collect();
        let mut out = Vec::new();
        for half in 0..13 {
            for pick in [f32::min as fn(f32, f32) -> f32, f32::max] {
                slide_1d(&line, half, pick, &mut out);
                for (i, &v) in out.iter().enumerate() {
                    let window = &line[i.saturating_sub(half)..(i + half + 1).min(line.len())];
                    assert_eq!(v, window.iter().copied().reduce(pick).unwrap(), "half {half}, i {i}");
                }
            }
        }
        // A 4-pixel stripe beside a 30-pixel bright area, one dark pixel between them: the stripe keeps its
        // contrast, the area and the road beside its edge get none.
        let (w, h) = (60, 20);
        let image: Vec<f32> = (0..w * h)
            .map(|i| {
                let c = i % w;
                if (10..14).contains(&c) {
                    0.9
                } else if (15..45).contains(&c) {
                    0.8
                } else {
                    0.1
                }
            })
            .collect();
        let (diff, _) = opening_difference(&image, &vec![true; w * h], w, h, 6);
        let at = |c: usize| diff[10 * w + c];
        assert!((at(11) - 0.8).abs() < 1e-5 && at(30).abs() < 1e-5 && at(50).abs() < 1e-5 && at(14).abs() < 1e-5);
    }

    #[test]
    fn the_window_mean_equals_the_brute_force_mean_and_a_flat_image_has_no_contrast() {
        let (w, h, half) = (13, 9, 2);
        let values: Vec<f32> = (0..w * h).map(|i| ((i * 37) % 11) as f32).collect();
        let counts: Vec<f32> = (0..w * h).map(|i| if i % 7 == 3 { 0.0 } else { 1.0 }).collect();
        let (mean, count) = window_mean(&values, &counts, w, h, half);
        for r in 0..h {
            for c in 0..w {
                let (mut s, mut n) = (0.0, 0.0);
                for rr in r.saturating_sub(half)..(r + half + 1).min(h) {
                    for cc in c.saturating_sub(half)..(c + half + 1).min(w) {
                        (s, n) = (s + values[rr * w + cc], n + counts[rr * w + cc]);
                    }
                }
                assert_eq!(count[r * w + c], n);
                assert!((mean[r * w + c] - s / n).abs() < 1e-5);
            }
        }
        let blocks = Blocks::new(10, 7, 3);
        let flat = vec![0.4f32; 70];
        let (bg, _) = blocks.box_mean(&flat, &[true; 70], 1);
        assert!(blocks.subtract(&flat, &bg).iter().all(|d| d.abs() < 1e-6));
    }
}
