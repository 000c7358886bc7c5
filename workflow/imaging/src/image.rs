//! A small f32 gray image (row-major) with bilinear sampling, and a boolean mask of the same shape.
//!
//! Pixel coordinates follow ARCHITECTURE.md: continuous, (0, 0) at the top-left corner of the top-left
//! pixel, u right, v down; pixel (col, row) has its centre at (col + 0.5, row + 0.5).

use rayon::prelude::*;

use crate::error::ImagingError;

/// A row-major f32 gray image.
#[derive(Clone, Debug, PartialEq)]
pub struct GrayImage {
    width: usize,
    height: usize,
    data: Vec<f32>,
}

impl GrayImage {
    /// Wrap a row-major buffer; `data.len()` must equal `width · height` and both must be positive.
    pub fn new(width: usize, height: usize, data: Vec<f32>) -> Result<Self, ImagingError> {
        if width == 0 || height == 0 || data.len() != width * height {
            return Err(ImagingError::Shape { what: "gray image", width, height, len: data.len() });
        }
        Ok(Self { width, height, data })
    }

    /// An image with every pixel set to `value` (a zero dimension yields an empty image).
    pub fn filled(width: usize, height: usize, value: f32) -> Self {
        Self { width, height, data: vec![value; width * height] }
    }

    /// An image whose pixel (col, row) is `f(col, row)`, computed row-parallel.
    pub fn from_fn(width: usize, height: usize, f: impl Fn(usize, usize) -> f32 + Sync) -> Self {
        let mut data = vec![0.0; width * height];
        if width > 0 {
            data.par_chunks_mut(width)
                .enumerate()
                .for_each(|(row, line)| line.iter_mut().enumerate().for_each(|(col, p)| *p = f(col, row)));
        }
        Self { width, height, data }
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// The row-major samples.
    pub fn data(&self) -> &[f32] {
        &self.data
    }

    /// The row-major samples, mutable.
    pub fn data_mut(&mut self) -> &mut [f32] {
        &mut self.data
    }

    /// One row of samples.
    pub fn row(&self, row: usize) -> &[f32] {
        &self.data[row * self.width..(row + 1) * self.width]
    }

    /// The sample of pixel (col, row); panics when outside (an indexing bug, not an input error).
    pub fn get(&self, col: usize, row: usize) -> f32 {
        self.data[row * self.width + col]
    }

    /// Set pixel (col, row).
    pub fn set(&mut self, col: usize, row: usize, value: f32) {
        self.data[row * self.width + col] = value;
    }

    /// The sample of pixel (col, row) with the index clamped into the image (edge replication).
    pub fn get_clamped(&self, col: isize, row: isize) -> f32 {
        let c = col.clamp(0, self.width as isize - 1) as usize;
        let r = row.clamp(0, self.height as isize - 1) as usize;
        self.data[r * self.width + c]
    }

    /// Bilinear sample at continuous (u, v); `None` outside the image extent [0, W) × [0, H).
    /// Within half a pixel of the border the edge pixels are replicated.
    pub fn sample(&self, u: f64, v: f64) -> Option<f32> {
        let inside = u >= 0.0 && v >= 0.0 && u < self.width as f64 && v < self.height as f64;
        inside.then(|| self.sample_clamped(u, v))
    }

    /// Bilinear sample at continuous (u, v) with edge replication everywhere (never fails; NaN in, NaN out).
    pub fn sample_clamped(&self, u: f64, v: f64) -> f32 {
        let (x, y) = (u - 0.5, v - 0.5);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
        let (c, r) = (x0 as isize, y0 as isize);
        let top = self.get_clamped(c, r) * (1.0 - fx) + self.get_clamped(c + 1, r) * fx;
        let bottom = self.get_clamped(c, r + 1) * (1.0 - fx) + self.get_clamped(c + 1, r + 1) * fx;
        top * (1.0 - fy) + bottom * fy
    }

    /// Mean of all samples.
    pub fn mean(&self) -> f64 {
        self.data.iter().map(|&x| f64::from(x)).sum::<f64>() / self.data.len().max(1) as f64
    }

    /// Apply `f` to every sample.
    pub fn map(&self, f: impl Fn(f32) -> f32 + Sync) -> Self {
        Self { width: self.width, height: self.height, data: self.data.par_iter().map(|&x| f(x)).collect() }
    }

    /// The `(2·half + 1)`² patch centred on pixel (col, row), or an error when it leaves the image.
    pub fn patch(&self, col: usize, row: usize, half: usize) -> Result<Self, ImagingError> {
        if col < half || row < half || col + half >= self.width || row + half >= self.height {
            return Err(self.out_of_bounds("patch", col as f64 + 0.5, row as f64 + 0.5, half));
        }
        let n = 2 * half + 1;
        Ok(Self::from_fn(n, n, |c, r| self.get(col + c - half, row + r - half)))
    }

    /// The out-of-bounds error for a window at (x, y).
    pub(crate) fn out_of_bounds(&self, what: &'static str, x: f64, y: f64, half: usize) -> ImagingError {
        ImagingError::OutOfBounds { what, x, y, half, width: self.width, height: self.height }
    }
}

/// Which pixels of a camera's full image a decoded image holds: the camera rows from `first_row` to the
/// bottom, each image column the mean of `col_step` neighbouring camera columns. Camera pixel (u, v) is
/// image pixel (u / col_step, v − first_row). A panorama is decoded to the part its ortho patch samples, so
/// a 16384 × 8192 panorama need not be held whole.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImagePart {
    full: (u32, u32),
    first_row: u32,
    col_step: u32,
}

impl ImagePart {
    /// The whole `width` × `height` image.
    pub const fn whole(width: u32, height: u32) -> Self {
        Self { full: (width, height), first_row: 0, col_step: 1 }
    }

    /// Rows `first_row..height` of a `width` × `height` camera image at one column per `col_step`; the
    /// step must divide the width and leave at least one row and column.
    pub fn new(width: u32, height: u32, first_row: u32, col_step: u32) -> Result<Self, ImagingError> {
        let ok = width > 0 && height > 0 && first_row < height && col_step > 0 && width.is_multiple_of(col_step);
        if !ok {
            let what = "image part (a column step dividing the width, a first row inside the image)";
            return Err(ImagingError::Shape { what, width: width as usize, height: height as usize, len: 0 });
        }
        Ok(Self { full: (width, height), first_row, col_step })
    }

    /// The camera image's (width, height).
    pub fn full(&self) -> (u32, u32) {
        self.full
    }

    /// First camera row held.
    pub fn first_row(&self) -> u32 {
        self.first_row
    }

    /// Camera columns per image column.
    pub fn col_step(&self) -> u32 {
        self.col_step
    }

    /// Width of the held image, pixels.
    pub fn width(&self) -> usize {
        (self.full.0 / self.col_step) as usize
    }

    /// Height of the held image, pixels.
    pub fn height(&self) -> usize {
        (self.full.1 - self.first_row) as usize
    }

    /// Whether this is the whole image.
    pub fn is_whole(&self) -> bool {
        self.first_row == 0 && self.col_step == 1
    }

    /// The part of `row_major` (the full image, one value per pixel) as a gray image: rows from
    /// `first_row`, every `col_step` columns averaged. `None` unless `row_major` has the full size.
    pub fn extract<T: Copy + Into<f32> + Sync>(&self, row_major: &[T]) -> Option<GrayImage> {
        let (w, h) = (self.full.0 as usize, self.full.1 as usize);
        if row_major.len() != w * h {
            return None;
        }
        let (step, first) = (self.col_step as usize, self.first_row as usize);
        let scale = 1.0 / step as f32;
        Some(GrayImage::from_fn(self.width(), self.height(), |c, r| {
            let row = &row_major[(first + r) * w..(first + r + 1) * w];
            let sum: f32 = row[c * step..(c + 1) * step].iter().map(|&v| v.into()).sum();
            sum * scale
        }))
    }
}

/// A boolean mask with the shape of an image; `true` marks a pixel as set (e.g. "vehicle" or "valid").
#[derive(Clone, Debug, PartialEq)]
pub struct Mask {
    width: usize,
    height: usize,
    data: Vec<bool>,
}

impl Mask {
    /// Wrap a row-major buffer; `data.len()` must equal `width · height`.
    pub fn new(width: usize, height: usize, data: Vec<bool>) -> Result<Self, ImagingError> {
        if width == 0 || height == 0 || data.len() != width * height {
            return Err(ImagingError::Shape { what: "mask", width, height, len: data.len() });
        }
        Ok(Self { width, height, data })
    }

    /// A mask whose pixel (col, row) is `f(col, row)`.
    pub fn from_fn(width: usize, height: usize, f: impl Fn(usize, usize) -> bool) -> Self {
        let data = (0..width * height).map(|i| f(i % width, i / width)).collect();
        Self { width, height, data }
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Pixel (col, row); panics when outside.
    pub fn get(&self, col: usize, row: usize) -> bool {
        self.data[row * self.width + col]
    }

    /// Number of set pixels.
    pub fn count(&self) -> usize {
        self.data.iter().filter(|&&b| b).count()
    }

    /// The row-major flags.
    pub fn data(&self) -> &[bool] {
        &self.data
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_image_part_needs_a_dividing_column_step_and_a_row_inside_and_averages_its_columns() {
        assert!(ImagePart::new(10, 4, 4, 1).is_err() && ImagePart::new(10, 4, 0, 3).is_err());
        assert!(ImagePart::new(10, 4, 0, 0).is_err() && ImagePart::new(0, 4, 0, 1).is_err());
        let part = ImagePart::new(10, 4, 1, 5).unwrap();
        assert_eq!((part.width(), part.height(), part.is_whole()), (2, 3, false));
        let pixels: Vec<u8> = (0..40).collect();
        let held = part.extract(&pixels).unwrap();
        // Row 1 of the part is camera row 2: columns 5..10 hold 25..30, mean 27.
        assert_eq!(held.get(1, 1), 27.0);
        assert!(part.extract(&pixels[1..]).is_none());
        assert!(ImagePart::whole(10, 4).is_whole());
    }

    #[test]
    fn bilinear_sampling_reproduces_a_linear_ramp_at_any_point() {
        // f = 2u + 3v at pixel centres; bilinear interpolation is exact for a linear function.
        let img = GrayImage::from_fn(20, 10, |c, r| 2.0 * (c as f32 + 0.5) + 3.0 * (r as f32 + 0.5));
        for (u, v) in [(0.5, 0.5), (3.25, 7.8), (10.0, 5.0), (19.49, 9.49), (7.77, 1.01)] {
            let s = img.sample(u, v).unwrap();
            assert!((f64::from(s) - (2.0 * u + 3.0 * v)).abs() < 1e-4, "({u}, {v}) -> {s}");
        }
        // Outside the extent there is no sample; inside the half-pixel band the edge is replicated.
        assert!(img.sample(-0.01, 3.0).is_none() && img.sample(20.0, 3.0).is_none());
        assert_eq!(img.sample(0.1, 0.5).unwrap(), img.get(0, 0));
    }

    #[test]
    fn shapes_are_checked_and_patches_stay_inside() {
        assert!(GrayImage::new(3, 3, vec![0.0; 8]).is_err());
        assert!(Mask::new(0, 3, vec![]).is_err());
        let img = GrayImage::from_fn(9, 9, |c, r| (c + 10 * r) as f32);
        let p = img.patch(4, 4, 2).unwrap();
        assert_eq!((p.get(0, 0), p.get(4, 4)), (22.0, 66.0));
        assert!(img.patch(1, 4, 2).is_err() && img.patch(4, 7, 2).is_err());
    }
}
