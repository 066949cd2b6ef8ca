//! Image quality of a rendered view against the per-pixel reference (ARCHITECTURE.md, Definitions: quality):
//! SSIM on 8-bit sRGB luma, PSNR and maximum absolute error on 8-bit RGB. This is the one
//! implementation every back-end reports through, so the numbers are comparable.
//!
//! SSIM follows Wang et al. 2004 exactly as scikit-image computes it with
//! `structural_similarity(a, b, gaussian_weights=True, sigma=1.5,
//! use_sample_covariance=False, data_range=255)`, which is the usual reference
//! implementation. It is checked against vectors that scikit-image produced
//! (`replay/tests/data/`); the arithmetic is done in the same order as SciPy and NumPy do it,
//! so the results agree bit for bit rather than only to a loose tolerance. [`compare`]
//! returns the results schema's [`Quality`], re-exported here.
//!
//! Alpha is ignored throughout: views are compared as the colours a viewer sees.

use rayon::prelude::*;

use crate::images::Rgba8Image;
pub use shadetrace_formats::results::Quality;

/// Side of the Gaussian SSIM window; images smaller than this in either dimension have no
/// SSIM (scikit-image raises an error for them).
pub const SSIM_WINDOW: u32 = 11;
/// Window radius: SciPy's `int(truncate * sigma + 0.5)` with truncate 3.5 and sigma 1.5.
const RADIUS: usize = 5;
const SIGMA: f64 = 1.5;
const K1: f64 = 0.01;
const K2: f64 = 0.03;
/// Dynamic range L of 8-bit data.
const DATA_RANGE: f64 = 255.0;

/// Luma of each pixel, Y = 0.2125 R + 0.7154 G + 0.0721 B (Rec. 709 weights), on the 8-bit values
/// (range 0..=255, not rounded). These are scikit-image's `rgb2gray` coefficients, so its
/// SSIM of the same data matches; unlike `rgb2gray` the values are not scaled to [0, 1],
/// which is why SSIM uses a data range of 255. Applied to the (gamma-encoded) sRGB codes,
/// as Wang et al. and most tools do, because that is what a viewer compares.
pub fn luma(img: &Rgba8Image) -> Vec<f64> {
    img.pixels
        .iter()
        .map(|&[r, g, b, _]| 0.2125 * f64::from(r) + 0.7154 * f64::from(g) + 0.0721 * f64::from(b))
        .collect()
}

/// Mean SSIM of two single-channel images of `width * height` values (row-major, on a
/// 0..=255 scale, e.g. from [`luma`]), averaged over the valid windows only (a border of
/// 5 pixels is excluded, as in scikit-image).
///
/// None when the images are smaller than [`SSIM_WINDOW`] in either dimension or a slice is
/// not `width * height` long. Identical inputs give exactly 1.0. The result does not
/// depend on the number of threads.
pub fn ssim(a: &[f64], b: &[f64], width: u32, height: u32) -> Option<f64> {
    let map = ssim_map(a, b, width, height)?;
    Some(mean_of_valid(&map, width, height))
}

/// Mean of an SSIM map over the valid windows, in NumPy's summation order.
fn mean_of_valid(map: &[f64], width: u32, height: u32) -> f64 {
    let (w, h) = (width as usize, height as usize);
    let cropped_width = w - 2 * RADIUS;
    let count = cropped_width * (h - 2 * RADIUS);
    // Sum in the order NumPy's `mean` does over the cropped (non-contiguous) map: whole
    // rows buffered in blocks of up to 8192 values, pairwise within a block, blocks added
    // in sequence. Any fixed order would be deterministic; this one also reproduces
    // scikit-image's result bit for bit.
    let rows_per_block = (8192 / cropped_width).max(1);
    let mut block = Vec::with_capacity(rows_per_block * cropped_width);
    let mut total = 0.0;
    for first in (RADIUS..h - RADIUS).step_by(rows_per_block) {
        block.clear();
        for y in first..(first + rows_per_block).min(h - RADIUS) {
            block.extend_from_slice(&map[y * w + RADIUS..(y + 1) * w - RADIUS]);
        }
        total += pairwise_sum(&block);
    }
    total / count as f64
}

/// Mean of an SSIM map over the valid windows centred on a covered pixel (`covered` is
/// row-major, one flag per pixel): orbit views are mostly background, which an image-wide
/// mean counts as perfect. None when no valid window is centred on a covered pixel.
fn mean_of_covered(map: &[f64], covered: &[bool], width: u32, height: u32) -> Option<f64> {
    let (w, h) = (width as usize, height as usize);
    let values: Vec<f64> = (RADIUS..h - RADIUS)
        .flat_map(|y| (RADIUS..w - RADIUS).map(move |x| y * w + x))
        .filter(|&i| covered[i])
        .map(|i| map[i])
        .collect();
    (!values.is_empty()).then(|| pairwise_sum(&values) / values.len() as f64)
}

/// The full per-pixel SSIM map (scikit-image's `full=True` output), border included, for
/// heat maps. Border pixels use windows that extend past the image, filled by half-sample
/// reflection (`d c b a | a b c d | d c b a`, SciPy's `mode='reflect'`); [`ssim`] excludes
/// them. Same preconditions as [`ssim`].
pub fn ssim_map(a: &[f64], b: &[f64], width: u32, height: u32) -> Option<Vec<f64>> {
    let (w, h) = (width as usize, height as usize);
    let count = w.checked_mul(h)?;
    if width < SSIM_WINDOW || height < SSIM_WINDOW || a.len() != count || b.len() != count {
        return None;
    }
    let weights = gaussian_weights();
    let c1 = (K1 * DATA_RANGE) * (K1 * DATA_RANGE);
    let c2 = (K2 * DATA_RANGE) * (K2 * DATA_RANGE);
    let mut map = vec![0.0; count];
    // Every output row is computed on its own (vertical pass for that row, then the
    // horizontal pass), so rows can run in parallel without changing any bit.
    map.par_chunks_mut(w).enumerate().for_each_init(
        || RowScratch::new(w),
        |scratch, (y, out)| {
            let row = SsimRow {
                a,
                b,
                width: w,
                height: h,
                y,
                weights: &weights,
                c1,
                c2,
            };
            scratch.ssim_row(&row, out)
        },
    );
    Some(map)
}

/// What one output row of the SSIM map is computed from: the two images, their size, the
/// row, the Gaussian weights and the stabilizing constants.
struct SsimRow<'a> {
    a: &'a [f64],
    b: &'a [f64],
    width: usize,
    height: usize,
    y: usize,
    weights: &'a [f64; 2 * RADIUS + 1],
    c1: f64,
    c2: f64,
}

/// Per-thread buffers for one output row of the five filtered quantities.
struct RowScratch {
    /// Vertically filtered x, y, x², y², xy, with `RADIUS` reflected columns on each side.
    vertical: [Vec<f64>; 5],
    /// Fully filtered means: ux, uy, uxx, uyy, uxy.
    filtered: [Vec<f64>; 5],
}

impl RowScratch {
    fn new(width: usize) -> Self {
        Self {
            vertical: std::array::from_fn(|_| vec![0.0; width + 2 * RADIUS]),
            filtered: std::array::from_fn(|_| vec![0.0; width]),
        }
    }

    /// Output row `y` of the SSIM map, in code built for AVX2 where the CPU has it. Its
    /// loops run pixel by pixel, so wider vectors do the same IEEE operations in the same
    /// order for each pixel (and AVX2 brings no fused multiply-add): the bits are the
    /// same on every machine, only 4 pixels go at a time instead of 2.
    fn ssim_row(&mut self, row: &SsimRow, out: &mut [f64]) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, checked just above.
            return unsafe { self.ssim_row_avx2(row, out) };
        }
        self.ssim_row_portable(row, out)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn ssim_row_avx2(&mut self, row: &SsimRow, out: &mut [f64]) {
        self.ssim_row_portable(row, out)
    }

    #[inline(always)]
    fn ssim_row_portable(&mut self, row: &SsimRow, out: &mut [f64]) {
        let &SsimRow {
            a,
            b,
            width: w,
            height: h,
            y,
            weights,
            c1,
            c2,
        } = row;
        self.filter_row(a, b, w, h, y, weights);
        let [ux, uy, uxx, uyy, uxy] = self.filtered.each_ref().map(|plane| &plane[..w]);
        for (x, s) in out[..w].iter_mut().enumerate() {
            let (ux, uy) = (ux[x], uy[x]);
            // scikit-image's expressions, term for term and in the same order.
            let vx = uxx[x] - ux * ux;
            let vy = uyy[x] - uy * uy;
            let vxy = uxy[x] - ux * uy;
            let a1 = 2.0 * ux * uy + c1;
            let a2 = 2.0 * vxy + c2;
            let b1 = ux * ux + uy * uy + c1;
            let b2 = vx + vy + c2;
            *s = (a1 * a2) / (b1 * b2);
        }
    }

    /// Gaussian-filters row `y` of x, y, x², y² and xy: first along columns (axis 0), then
    /// along the row (axis 1), the order of `scipy.ndimage.gaussian_filter`. Each output
    /// sums its taps in SciPy's `correlate1d` order for a symmetric kernel (centre first,
    /// then each outermost pair's sum times its weight, inward), so every bit is SciPy's;
    /// the loops run tap by tap along whole rows, which reads memory in order and vectorizes.
    #[inline(always)]
    fn filter_row(&mut self, a: &[f64], b: &[f64], w: usize, h: usize, y: usize, weights: &[f64; 2 * RADIUS + 1]) {
        let rows: [usize; 2 * RADIUS + 1] =
            std::array::from_fn(|k| reflect(y as isize + k as isize - RADIUS as isize, h));
        fn row<'i>(img: &'i [f64], rows: &[usize], k: usize, w: usize) -> &'i [f64] {
            &img[rows[k] * w..(rows[k] + 1) * w]
        }
        // Every slice is re-cut to exactly `w` so that the loops carry no bounds checks.
        let [vx, vy, vxx, vyy, vxy] = self
            .vertical
            .each_mut()
            .map(|plane| &mut plane[RADIUS..RADIUS + w][..w]);
        let (centre_a, centre_b, wc) = (
            &row(a, &rows, RADIUS, w)[..w],
            &row(b, &rows, RADIUS, w)[..w],
            weights[RADIUS],
        );
        for x in 0..w {
            let (p, q) = (centre_a[x], centre_b[x]);
            vx[x] = p * wc;
            vy[x] = q * wc;
            vxx[x] = (p * p) * wc;
            vyy[x] = (q * q) * wc;
            vxy[x] = (p * q) * wc;
        }
        for d in (1..=RADIUS).rev() {
            let (lo_a, hi_a) = (&row(a, &rows, RADIUS - d, w)[..w], &row(a, &rows, RADIUS + d, w)[..w]);
            let (lo_b, hi_b) = (&row(b, &rows, RADIUS - d, w)[..w], &row(b, &rows, RADIUS + d, w)[..w]);
            let wd = weights[RADIUS - d];
            for x in 0..w {
                let (p0, p1, q0, q1) = (lo_a[x], hi_a[x], lo_b[x], hi_b[x]);
                vx[x] += (p0 + p1) * wd;
                vy[x] += (q0 + q1) * wd;
                vxx[x] += (p0 * p0 + p1 * p1) * wd;
                vyy[x] += (q0 * q0 + q1 * q1) * wd;
                vxy[x] += (p0 * q0 + p1 * q1) * wd;
            }
        }
        // The padding columns are reflected columns: their vertical sums are those columns'.
        for plane in &mut self.vertical {
            for p in (0..RADIUS).chain(w + RADIUS..w + 2 * RADIUS) {
                plane[p] = plane[RADIUS + reflect(p as isize - RADIUS as isize, w)];
            }
        }
        for (vertical, out) in self.vertical.iter().zip(&mut self.filtered) {
            let (out, centre) = (&mut out[..w], &vertical[RADIUS..RADIUS + w][..w]);
            for x in 0..w {
                out[x] = centre[x] * wc;
            }
            for d in (1..=RADIUS).rev() {
                let wd = weights[RADIUS - d];
                let (lo, hi) = (
                    &vertical[RADIUS - d..RADIUS - d + w][..w],
                    &vertical[RADIUS + d..RADIUS + d + w][..w],
                );
                for x in 0..w {
                    out[x] += (lo[x] + hi[x]) * wd;
                }
            }
        }
    }
}

/// SciPy's `mode='reflect'` (half-sample symmetric) for any offset, including several
/// image lengths away.
fn reflect(i: isize, len: usize) -> usize {
    let period = 2 * len as isize;
    let i = i.rem_euclid(period) as usize;
    if i < len {
        i
    } else {
        2 * len - 1 - i
    }
}

/// SciPy's `_gaussian_kernel1d(1.5, 0, 5)`: exp(-x² / 2σ²) normalized to sum 1, with the
/// sum taken in NumPy's order. `libm::exp` keeps it identical on every platform.
fn gaussian_weights() -> [f64; 2 * RADIUS + 1] {
    let scale = -0.5 / (SIGMA * SIGMA);
    let phi: [f64; 2 * RADIUS + 1] = std::array::from_fn(|k| {
        let x = k as f64 - RADIUS as f64;
        libm::exp(scale * (x * x))
    });
    let sum = pairwise_sum(&phi);
    phi.map(|v| v / sum)
}

/// NumPy's pairwise summation of float64 (`pairwise_sum_DOUBLE`): plain loop below 8
/// values, 8 interleaved accumulators up to 128, recursive halving above.
fn pairwise_sum(v: &[f64]) -> f64 {
    let n = v.len();
    if n < 8 {
        v.iter().fold(0.0, |acc, &x| acc + x)
    } else if n <= 128 {
        let mut r: [f64; 8] = std::array::from_fn(|j| v[j]);
        let full = n - n % 8;
        for chunk in v[8..full].chunks_exact(8) {
            for (acc, &x) in r.iter_mut().zip(chunk) {
                *acc += x;
            }
        }
        let head = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
        v[full..].iter().fold(head, |acc, &x| acc + x)
    } else {
        let half = n / 2;
        let half = half - half % 8;
        pairwise_sum(&v[..half]) + pairwise_sum(&v[half..])
    }
}

/// Whether two images can be compared pixel for pixel: same size, complete pixel buffers,
/// at least one pixel.
fn comparable(a: &Rgba8Image, b: &Rgba8Image) -> bool {
    let count = (a.width as usize).checked_mul(a.height as usize);
    (a.width, a.height) == (b.width, b.height)
        && count == Some(a.pixels.len())
        && count == Some(b.pixels.len())
        && !a.pixels.is_empty()
}

/// PSNR in dB over the R, G and B channels with MAX = 255 (scikit-image's
/// `peak_signal_noise_ratio(a, b, data_range=255)` on the RGB arrays).
///
/// Identical images give `f64::INFINITY`, which JSON cannot represent: reports should use
/// [`psnr_for_report`] (None for identical images), as [`compare`] does. NaN when the images
/// are not [comparable](compare) (different sizes, incomplete buffers, no pixels).
pub fn psnr(a: &Rgba8Image, b: &Rgba8Image) -> f64 {
    if !comparable(a, b) {
        return f64::NAN;
    }
    let squares: u64 = a.pixels.iter().zip(&b.pixels).map(|(p, q)| rgb_squares(p, q)).sum();
    psnr_of(squares, a.pixels.len())
}

/// PSNR from the sum of the R, G and B codes' squared differences over `pixels` pixels.
fn psnr_of(squares: u64, pixels: usize) -> f64 {
    let mse = squares as f64 / (3 * pixels) as f64;
    10.0 * libm::log10((DATA_RANGE * DATA_RANGE) / mse)
}

/// The squared differences of two pixels' R, G and B codes, summed: integers, so exact
/// in any order (at most 3 * 255², a u32, so that loops over pixels vectorize).
#[inline]
fn rgb_squares(p: &[u8; 4], q: &[u8; 4]) -> u64 {
    let d = [0, 1, 2].map(|c| u32::from(p[c].abs_diff(q[c])));
    u64::from(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
}

/// [`psnr`] as it goes into a report: None instead of infinity (identical images) or NaN
/// (images that cannot be compared), since JSON has neither.
pub fn psnr_for_report(a: &Rgba8Image, b: &Rgba8Image) -> Option<f64> {
    reported(psnr(a, b))
}

/// A PSNR as reports carry it: None for infinity or NaN, which JSON has not.
fn reported(psnr: f64) -> Option<f64> {
    Some(psnr).filter(|v| v.is_finite())
}

/// Largest absolute difference of any R, G or B code between corresponding pixels.
/// Images that cannot be compared (different sizes, incomplete buffers, no pixels) give
/// 255, the worst possible value, rather than a misleadingly small one.
pub fn max_abs_error(a: &Rgba8Image, b: &Rgba8Image) -> u8 {
    if !comparable(a, b) {
        return u8::MAX;
    }
    a.pixels
        .iter()
        .zip(&b.pixels)
        .map(|(p, q)| rgb_difference(p, q))
        .max()
        .unwrap_or(0)
}

/// The largest difference of two pixels' R, G and B codes (written out, so loops over
/// pixels vectorize).
#[inline]
fn rgb_difference(p: &[u8; 4], q: &[u8; 4]) -> u8 {
    p[0].abs_diff(q[0]).max(p[1].abs_diff(q[1])).max(p[2].abs_diff(q[2]))
}

/// What comparing a view with the reference finds: the metrics, and the per-pixel maps
/// (for pictures of where the loss is).
pub struct Comparison {
    pub quality: Quality,
    /// Per-pixel SSIM; None where the views are smaller than the SSIM window.
    pub ssim_map: Option<Vec<f64>>,
    /// Per pixel, the largest difference of the RGB codes.
    pub error_map: Vec<u8>,
}

/// All quality metrics of `test` against `reference` (ARCHITECTURE.md, Definitions:
/// quality), with the covered-pixel SSIM over the pixels where `covered` is true (one flag
/// per pixel, row-major; the reference's covered pixels). `ssim` is None for images smaller
/// than 11x11 and `psnr_db` is None when the images are identical. Errors when the images
/// differ in size, have no pixels, or have a pixel buffer (or mask) that is not
/// `width * height` long.
pub fn compare(reference: &Rgba8Image, test: &Rgba8Image, covered: &[bool]) -> Result<Quality, String> {
    compare_views(reference, &luma(reference), test, covered).map(|c| c.quality)
}

/// [`compare`], given the reference's [`luma`] (a reference is compared with every preset,
/// so its caller computes that once), with the maps behind the metrics.
pub fn compare_views(
    reference: &Rgba8Image,
    reference_luma: &[f64],
    test: &Rgba8Image,
    covered: &[bool],
) -> Result<Comparison, String> {
    if (reference.width, reference.height) != (test.width, test.height) {
        return Err(format!(
            "cannot compare a {}x{} image with a {}x{} reference",
            test.width, test.height, reference.width, reference.height
        ));
    }
    if !comparable(reference, test) {
        return Err(format!(
            "cannot compare {}x{} images with {} and {} pixels",
            test.width,
            test.height,
            reference.pixels.len(),
            test.pixels.len()
        ));
    }
    if covered.len() != reference.pixels.len() {
        return Err(format!(
            "a coverage mask of {} pixels for {} pixels",
            covered.len(),
            reference.pixels.len()
        ));
    }
    if reference_luma.len() != reference.pixels.len() {
        return Err(format!(
            "a reference luma of {} values for {} pixels",
            reference_luma.len(),
            reference.pixels.len()
        ));
    }
    let (w, h) = (reference.width, reference.height);
    let map = ssim_map(reference_luma, &luma(test), w, h);
    // The RGB errors in one pass: the error map, the PSNR's squares and the largest.
    let mut squares = 0u64;
    let error_map: Vec<u8> = reference
        .pixels
        .iter()
        .zip(&test.pixels)
        .map(|(p, q)| {
            squares += rgb_squares(p, q);
            rgb_difference(p, q)
        })
        .collect();
    let quality = Quality {
        ssim: map.as_ref().map(|m| mean_of_valid(m, w, h)),
        ssim_covered: map.as_ref().and_then(|m| mean_of_covered(m, covered, w, h)),
        psnr_db: reported(psnr_of(squares, reference.pixels.len())),
        max_abs_error: error_map.iter().copied().max().unwrap_or(0),
    };
    Ok(Comparison {
        quality,
        ssim_map: map,
        error_map,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic pseudo-random image (64-bit LCG), so tests need no data files.
    fn noise_image(width: u32, height: u32, seed: u64) -> Rgba8Image {
        let mut state = seed;
        let mut image = Rgba8Image::new(width, height);
        for p in &mut image.pixels {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            let [r, g, b, a, ..] = (state >> 16).to_le_bytes();
            *p = [r, g, b, a];
        }
        image
    }

    /// The AVX2 build of a row gives the portable build's bits, so results do not depend
    /// on the machine (rows at the borders included, where windows reflect).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn ssim_rows_are_the_same_bits_with_and_without_avx2() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        let (w, h) = (37, 23);
        let (a, b) = (luma(&noise_image(w, h, 1)), luma(&noise_image(w, h, 2)));
        let (w, h) = (w as usize, h as usize);
        let weights = gaussian_weights();
        let mut scratch = RowScratch::new(w);
        for y in 0..h {
            let row = SsimRow {
                a: &a,
                b: &b,
                width: w,
                height: h,
                y,
                weights: &weights,
                c1: (K1 * DATA_RANGE).powi(2),
                c2: (K2 * DATA_RANGE).powi(2),
            };
            let (mut portable, mut wide) = (vec![0.0; w], vec![0.0; w]);
            scratch.ssim_row_portable(&row, &mut portable);
            // SAFETY: the CPU has AVX2, checked above.
            unsafe { scratch.ssim_row_avx2(&row, &mut wide) };
            let bits = |row: &[f64]| row.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&wide), bits(&portable), "row {y}");
        }
    }

    fn all(img: &Rgba8Image) -> Vec<bool> {
        vec![true; img.pixels.len()]
    }

    /// Error confined to a covered region of a mostly empty frame: the image-wide mean counts
    /// the background as perfect, the covered-pixel mean does not.
    #[test]
    fn covered_pixel_ssim_excludes_the_background() {
        let (w, h) = (64u32, 48u32);
        let reference = noise_image(w, h, 7);
        let mut test = reference.clone();
        let inside = |x: u32, y: u32| (20..36).contains(&x) && (16..30).contains(&y);
        for y in 0..h {
            for x in 0..w {
                if inside(x, y) {
                    let p = reference.get(x, y).unwrap();
                    test.set(x, y, [p[0] / 2, p[1] / 2, p[2] / 2, 255]);
                }
            }
        }
        let covered: Vec<bool> = (0..w * h).map(|i| inside(i % w, i / w)).collect();
        let q = compare(&reference, &test, &covered).unwrap();
        let (whole, region) = (q.ssim.unwrap(), q.ssim_covered.unwrap());
        assert!(region < whole - 0.1, "covered {region} vs whole {whole}");
        let everything = compare(&reference, &test, &all(&reference)).unwrap();
        assert!((everything.ssim_covered.unwrap() - whole).abs() < 1e-12);
        let nothing = compare(&reference, &test, &vec![false; covered.len()]).unwrap();
        assert_eq!(nothing.ssim_covered, None);
    }

    #[test]
    fn identical_images_are_exactly_similar() {
        for (w, h) in [(11, 11), (40, 23), (300, 17)] {
            let img = noise_image(w, h, u64::from(w));
            let y = luma(&img);
            assert_eq!(ssim(&y, &y, w, h), Some(1.0));
            assert!(ssim_map(&y, &y, w, h).unwrap().iter().all(|&s| s == 1.0));
            let flat = vec![0.0; y.len()];
            assert_eq!(ssim(&flat, &flat, w, h), Some(1.0));
            let q = compare(&img, &img, &all(&img)).unwrap();
            assert_eq!((q.ssim, q.psnr_db, q.max_abs_error), (Some(1.0), None, 0));
            assert_eq!(psnr(&img, &img), f64::INFINITY);
        }
    }

    #[test]
    fn ssim_is_symmetric_and_bounded() {
        let (a, b) = (luma(&noise_image(29, 31, 1)), luma(&noise_image(29, 31, 2)));
        let ab = ssim(&a, &b, 29, 31).unwrap();
        assert_eq!(ab.to_bits(), ssim(&b, &a, 29, 31).unwrap().to_bits());
        assert!((-1.0..1.0).contains(&ab));
    }

    #[test]
    fn too_small_or_inconsistent_inputs_have_no_ssim() {
        let y = vec![1.0; 10 * 20];
        assert_eq!(ssim(&y, &y, 10, 20), None);
        assert_eq!(ssim(&y, &y, 20, 10), None);
        assert_eq!(ssim(&y, &y, 0, 0), None);
        assert_eq!(ssim(&y, &y[1..], 11, 11), None);
        assert_eq!(ssim_map(&y, &y, 11, 19), None, "200 values for 11x19");
        let small = noise_image(8, 8, 3);
        let q = compare(&small, &noise_image(8, 8, 4), &all(&small)).unwrap();
        assert_eq!(q.ssim, None);
        assert!(q.psnr_db.is_some());
    }

    #[test]
    fn psnr_and_max_error_use_rgb_only() {
        let a = Rgba8Image::filled(4, 4, [10, 20, 30, 255]);
        let mut b = Rgba8Image::filled(4, 4, [10, 20, 30, 0]);
        assert_eq!(psnr(&a, &b), f64::INFINITY, "alpha is ignored");
        assert_eq!(psnr_for_report(&a, &b), None);
        b.set(1, 2, [10, 25, 27, 0]);
        assert_eq!(max_abs_error(&a, &b), 5);
        // MSE = (25 + 9) / 48.
        let expected = 10.0 * (255.0f64 * 255.0 / (34.0 / 48.0)).log10();
        assert!((psnr(&a, &b) - expected).abs() < 1e-12);
        assert_eq!(psnr_for_report(&a, &b), Some(psnr(&a, &b)));
    }

    #[test]
    fn mismatched_images_are_rejected() {
        let a = Rgba8Image::new(4, 4);
        assert!(compare(&a, &Rgba8Image::new(4, 5), &all(&a)).is_err());
        assert!(compare(&Rgba8Image::new(0, 0), &Rgba8Image::new(0, 0), &[]).is_err());
        let mut short = Rgba8Image::new(4, 4);
        short.pixels.pop();
        assert!(compare(&a, &short, &all(&a)).is_err());
        assert!(compare(&a, &a, &[true; 3]).is_err(), "a mask of the wrong size");
        assert!(psnr(&a, &short).is_nan());
        assert_eq!(psnr_for_report(&a, &short), None);
        assert_eq!(max_abs_error(&a, &short), 255);
    }

    #[test]
    fn mean_order_only_changes_rounding() {
        // Wide images exercise multi-row blocks (990 columns: 8 rows per block) and
        // single-row blocks (9000 columns).
        for (w, h) in [(1000, 23), (9010, 12)] {
            let (a, b) = (luma(&noise_image(w, h, 5)), luma(&noise_image(w, h, 6)));
            let map = ssim_map(&a, &b, w, h).unwrap();
            let (w, h) = (w as usize, h as usize);
            let valid: Vec<f64> = (5..h - 5)
                .flat_map(|y| map[y * w + 5..(y + 1) * w - 5].to_vec())
                .collect();
            let naive = valid.iter().sum::<f64>() / valid.len() as f64;
            let got = ssim(&a, &b, w as u32, h as u32).unwrap();
            assert!((got - naive).abs() < 1e-12, "{got} vs {naive}");
        }
    }

    #[test]
    fn numpy_pairwise_sum_and_scipy_reflect() {
        let v: Vec<f64> = (0..1000).map(|i| f64::from(i) * 0.5).collect();
        for n in [0, 1, 7, 8, 9, 127, 128, 129, 1000] {
            assert_eq!(pairwise_sum(&v[..n]), v[..n].iter().sum::<f64>());
        }
        let mapped: Vec<usize> = (-5..9).map(|i| reflect(i, 4)).collect();
        assert_eq!(mapped, [3, 3, 2, 1, 0, 0, 1, 2, 3, 3, 2, 1, 0, 0]);
        assert_eq!(reflect(0, 1), 0);
        assert_eq!(reflect(-7, 1), 0);
        let w = gaussian_weights();
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        assert_eq!(w[0], w[10]);
    }
}
