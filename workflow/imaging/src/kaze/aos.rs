//! The additive operator splitting (AOS) step of KAZE's scale space (Alcantarilla et al. 2012 eq. (8)): the tridiagonal
//! systems along rows are solved row by row, those along columns for all columns at once, sweeping down the
//! rows, so both loops run over contiguous rows and nothing is transposed.

use rayon::prelude::*;

use crate::image::GrayImage;

/// One AOS step of size τ: L' = ½ [(I − 2τA_x)⁻¹ + (I − 2τA_y)⁻¹] L (Alcantarilla et al. 2012 eq. (8)), A the 1-D
/// diffusion operator with half-point conductances (g_i + g_{i+1})/2.
pub(crate) fn aos_step(l: &GrayImage, g: &GrayImage, tau: f32) -> GrayImage {
    let (mut ux, uy) = rayon::join(|| solve_rows(l, g, tau), || solve_columns(l, g, tau));
    ux.data_mut().iter_mut().zip(uy.data()).for_each(|(a, &b)| *a = 0.5 * (*a + b));
    ux
}

/// Rows solved together by [`solve_rows`]: the Thomas recursion is sequential along a row, so rows are
/// interleaved and their recursions run side by side in vector lanes.
const LANES: usize = 8;

/// (I − 2τA_x)⁻¹ f for every row: [`thomas`] on blocks of [`LANES`] rows at once, to the bit.
pub(crate) fn solve_rows(f: &GrayImage, g: &GrayImage, tau: f32) -> GrayImage {
    let w = f.width();
    let mut out = GrayImage::filled(w, f.height(), 0.0);
    if w > 0 {
        out.data_mut().par_chunks_mut(w * LANES).enumerate().for_each_init(
            || Lanes::new(w),
            |lanes, (block, u)| {
                let first = block * LANES;
                if u.len() == w * LANES {
                    lanes.solve(f, g, first, tau, u);
                } else {
                    for (k, line) in u.chunks_mut(w).enumerate() {
                        thomas(f.row(first + k), g.row(first + k), tau, &mut lanes.upper, line);
                    }
                }
            },
        );
    }
    out
}

/// Interleaved scratch of [`LANES`] rows: sample i of lane k at `i * LANES + k`.
struct Lanes {
    f: Vec<f32>,
    g: Vec<f32>,
    upper: Vec<f32>,
    u: Vec<f32>,
}

impl Lanes {
    fn new(w: usize) -> Self {
        let n = w * LANES;
        Self { f: vec![0.0; n], g: vec![0.0; n], upper: vec![0.0; n], u: vec![0.0; n] }
    }

    /// Rows `first..first + LANES` of (I − 2τA_x)⁻¹ f into `out` (those rows, row-major): the arithmetic of
    /// [`thomas`], lane by lane.
    fn solve(&mut self, f: &GrayImage, g: &GrayImage, first: usize, tau: f32, out: &mut [f32]) {
        let w = f.width();
        for k in 0..LANES {
            let (fr, gr) = (f.row(first + k), g.row(first + k));
            for i in 0..w {
                self.f[i * LANES + k] = fr[i];
                self.g[i * LANES + k] = gr[i];
            }
        }
        let (mut left, mut up_prev, mut u_prev) = ([0.0f32; LANES], [0.0f32; LANES], [0.0f32; LANES]);
        for i in 0..w {
            let mut right = [0.0f32; LANES];
            if i + 1 < w {
                let (gi, gn) = (&self.g[i * LANES..(i + 1) * LANES], &self.g[(i + 1) * LANES..(i + 2) * LANES]);
                for k in 0..LANES {
                    right[k] = tau * (gi[k] + gn[k]);
                }
            }
            let (fi, upper, u) = (
                &self.f[i * LANES..(i + 1) * LANES],
                &mut self.upper[i * LANES..(i + 1) * LANES],
                &mut self.u[i * LANES..(i + 1) * LANES],
            );
            for k in 0..LANES {
                let inv = 1.0 / (1.0 + left[k] + right[k] - left[k] * up_prev[k]);
                up_prev[k] = right[k] * inv;
                u_prev[k] = (fi[k] + left[k] * u_prev[k]) * inv;
                upper[k] = up_prev[k];
                u[k] = u_prev[k];
            }
            left = right;
        }
        for i in (0..w.saturating_sub(1)).rev() {
            let (head, tail) = self.u.split_at_mut((i + 1) * LANES);
            let (ui, next, upper) = (&mut head[i * LANES..], &tail[..LANES], &self.upper[i * LANES..(i + 1) * LANES]);
            for k in 0..LANES {
                ui[k] += upper[k] * next[k];
            }
        }
        for (k, line) in out.chunks_mut(w).enumerate() {
            for (i, x) in line.iter_mut().enumerate() {
                *x = self.u[i * LANES + k];
            }
        }
    }
}

/// Solve (I − 2τA) u = f along one line by the Thomas algorithm; the link between samples i and i + 1 is
/// 2τ (g_i + g_{i+1})/2 (Alcantarilla et al. 2012 eq. (8)).
fn thomas(f: &[f32], g: &[f32], tau: f32, upper: &mut [f32], u: &mut [f32]) {
    let w = f.len();
    let (mut left, mut up_prev, mut u_prev) = (0.0f32, 0.0f32, 0.0f32);
    for i in 0..w {
        let right = if i + 1 < w { tau * (g[i] + g[i + 1]) } else { 0.0 };
        let inv = 1.0 / (1.0 + left + right - left * up_prev);
        up_prev = right * inv;
        u_prev = (f[i] + left * u_prev) * inv;
        upper[i] = up_prev;
        u[i] = u_prev;
        left = right;
    }
    for i in (0..w.saturating_sub(1)).rev() {
        u[i] += upper[i] * u[i + 1];
    }
}

/// (I − 2τA_y)⁻¹ f for every column: the Thomas algorithm run on all columns at once, one row at a time.
pub(crate) fn solve_columns(f: &GrayImage, g: &GrayImage, tau: f32) -> GrayImage {
    let (w, h) = (f.width(), f.height());
    let mut u = GrayImage::filled(w, h, 0.0);
    let mut upper = vec![0.0f32; w * h];
    let (mut left, mut right, zeros) = (vec![0.0f32; w], vec![0.0f32; w], vec![0.0f32; w]);
    let data = u.data_mut();
    for r in 0..h {
        let (fr, gr) = (&f.row(r)[..w], &g.row(r)[..w]);
        if r + 1 < h {
            let gn = &g.row(r + 1)[..w];
            right.iter_mut().zip(gr.iter().zip(gn)).for_each(|(x, (a, b))| *x = tau * (a + b));
        } else {
            right.fill(0.0);
        }
        let (done, rest) = data.split_at_mut(r * w);
        let (up_done, up_rest) = upper.split_at_mut(r * w);
        let (u_prev, up_prev) =
            if r == 0 { (&zeros[..], &zeros[..]) } else { (&done[(r - 1) * w..], &up_done[(r - 1) * w..]) };
        let (ur, upr, u_prev, up_prev) = (&mut rest[..w], &mut up_rest[..w], &u_prev[..w], &up_prev[..w]);
        let (lf, rt) = (&left[..w], &right[..w]);
        for c in 0..w {
            let inv = 1.0 / (1.0 + lf[c] + rt[c] - lf[c] * up_prev[c]);
            upr[c] = rt[c] * inv;
            ur[c] = (fr[c] + lf[c] * u_prev[c]) * inv;
        }
        std::mem::swap(&mut left, &mut right);
    }
    for r in (0..h.saturating_sub(1)).rev() {
        let (head, tail) = data.split_at_mut((r + 1) * w);
        let (ur, un, upr) = (&mut head[r * w..], &tail[..w], &upper[r * w..(r + 1) * w]);
        for c in 0..w {
            ur[c] += upr[c] * un[c];
        }
    }
    u
}

#[cfg(test)]
mod tests {
    use super::*;

    /// (I − 2τA) u along rows (`rows`) or columns, computed directly from the definition.
    fn apply(u: &GrayImage, g: &GrayImage, tau: f32, rows: bool) -> GrayImage {
        let (w, h) = (u.width() as isize, u.height() as isize);
        GrayImage::from_fn(u.width(), u.height(), |c, r| {
            let (c, r) = (c as isize, r as isize);
            let at = |im: &GrayImage, k: isize| {
                if rows { im.get(k as usize, r as usize) } else { im.get(c as usize, k as usize) }
            };
            let (i, n) = if rows { (c, w) } else { (r, h) };
            let mut out = at(u, i);
            for j in [i - 1, i + 1] {
                if (0..n).contains(&j) {
                    out -= tau * (at(g, i) + at(g, j)) * (at(u, j) - at(u, i));
                }
            }
            out
        })
    }

    #[test]
    fn both_sweeps_solve_their_tridiagonal_systems() {
        let f = GrayImage::from_fn(37, 23, |c, r| ((c * 31 + r * 17) % 11) as f32 * 0.1);
        let g = GrayImage::from_fn(37, 23, |c, r| 0.1 + ((c * 7 + r * 3) % 5) as f32 * 0.2);
        let tau = 2.5;
        for (rows, u) in [(true, solve_rows(&f, &g, tau)), (false, solve_columns(&f, &g, tau))] {
            let back = apply(&u, &g, tau, rows);
            let worst = back.data().iter().zip(f.data()).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
            assert!(worst < 1e-4, "rows={rows}: residual {worst}");
        }
    }

    /// Rows solved in lanes equal rows solved one by one, to the bit, whether a block is full or not.
    #[test]
    fn lanes_give_the_single_row_solution_to_the_bit() {
        for (w, h) in [(37, 23), (1, 9), (2, 8), (40, 3)] {
            let f = GrayImage::from_fn(w, h, |c, r| ((c * 31 + r * 17) % 11) as f32 * 0.1);
            let g = GrayImage::from_fn(w, h, |c, r| 0.1 + ((c * 7 + r * 3) % 5) as f32 * 0.2);
            let mut upper = vec![0.0; w];
            let mut one_by_one = GrayImage::filled(w, h, 0.0);
            for (r, line) in one_by_one.data_mut().chunks_mut(w).enumerate() {
                thomas(f.row(r), g.row(r), 2.5, &mut upper, line);
            }
            assert_eq!(solve_rows(&f, &g, 2.5), one_by_one, "{w} × {h}");
        }
    }
}
