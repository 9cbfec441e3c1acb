//! The separable Gaussian blur of the scale space, the same sums as
//! `rperc_core::image::GrayImage::gaussian_blur` in the same order (so bit-identical),
//! but with the kernel computed once per level and the border reflection
//! (`BORDER_REFLECT_101`) paid only within a radius of the edges: the interior runs
//! on plain slices, and the vertical pass accumulates whole rows so it vectorises.

use rperc_core::image::GrayImage;

/// Index `i` reflected into `0..n` without repeating the edge (`-1 -> 1`, `n -> n-2`).
fn reflect101(i: isize, n: usize) -> usize {
    if n == 1 {
        return 0;
    }
    let n = n as isize;
    let period = 2 * (n - 1);
    let m = i.rem_euclid(period);
    (if m < n { m } else { period - m }) as usize
}

/// Blurs `src` by the normalised `kernel` (odd length) into `out`; `scratch` holds the
/// horizontal pass. Buffers are resized and reused.
pub fn blur(src: &GrayImage, kernel: &[f32], scratch: &mut GrayImage, out: &mut GrayImage) {
    let (w, h) = (src.width, src.height);
    for img in [&mut *scratch, &mut *out] {
        img.width = w;
        img.height = h;
        img.data.clear();
        img.data.resize(w * h, 0.0);
    }
    if w == 0 || h == 0 {
        return;
    }
    for y in 0..h {
        let row = &src.data[y * w..(y + 1) * w];
        horizontal(row, kernel, &mut scratch.data[y * w..(y + 1) * w]);
    }
    let r = kernel.len() / 2;
    for y in 0..h {
        let dst = &mut out.data[y * w..(y + 1) * w];
        for (k, &wk) in kernel.iter().enumerate() {
            let yy = reflect101(y as isize + k as isize - r as isize, h);
            let line = &scratch.data[yy * w..(yy + 1) * w];
            for (d, &s) in dst.iter_mut().zip(line) {
                *d += wk * s;
            }
        }
    }
}

/// One row convolved with `kernel`, reflected at its ends.
fn horizontal(row: &[f32], kernel: &[f32], dst: &mut [f32]) {
    let (w, r) = (row.len(), kernel.len() / 2);
    let reflected = |x: usize| {
        kernel.iter().enumerate().fold(0.0f32, |acc, (k, &wk)| {
            acc + wk * row[reflect101(x as isize + k as isize - r as isize, w)]
        })
    };
    if w <= 2 * r {
        for (x, d) in dst.iter_mut().enumerate() {
            *d = reflected(x);
        }
        return;
    }
    for x in (0..r).chain(w - r..w) {
        dst[x] = reflected(x);
    }
    for (x, d) in dst.iter_mut().enumerate().take(w - r).skip(r) {
        *d = kernel
            .iter()
            .zip(&row[x - r..=x + r])
            .fold(0.0f32, |acc, (&wk, &g)| acc + wk * g);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rperc_core::image::gaussian_kernel;

    /// Against the core's blur, the reference, on sizes smaller and larger than the
    /// kernel: equal to the last bit or within float rounding.
    #[test]
    fn matches_the_core_blur() {
        for (w, h, sigma) in [
            (13, 9, 1.3),
            (3, 40, 2.0),
            (64, 2, 0.8),
            (31, 27, 3.0),
            (1, 1, 1.0),
        ] {
            let img = GrayImage {
                data: (0..w * h).map(|i| ((i * 37) % 101) as f32 * 1.7).collect(),
                width: w,
                height: h,
            };
            let (mut s1, mut a) = (GrayImage::default(), GrayImage::default());
            img.gaussian_blur(sigma, &mut s1, &mut a).unwrap();
            let (mut s2, mut b) = (GrayImage::default(), GrayImage::default());
            blur(&img, &gaussian_kernel(sigma), &mut s2, &mut b);
            assert_eq!((b.width, b.height), (w, h));
            for (x, y) in a.data.iter().zip(&b.data) {
                assert!(
                    (x - y).abs() <= 1e-4 * x.abs().max(1.0),
                    "{w}x{h} s {sigma}: {x} {y}"
                );
            }
        }
    }
}
