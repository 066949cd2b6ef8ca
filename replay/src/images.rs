//! 8-bit RGBA images and the picture outputs of a replay: per-view PNGs, side-by-side
//! stereo pairs and heat maps (per-pixel shading cost, refinement, SSIM) with a legend.
//!
//! Everything here is deterministic (no clocks, no thread-dependent order, fixed PNG
//! settings), so the same replay writes byte-identical files (ARCHITECTURE.md, Definitions: determinism), and nothing
//! panics on odd sizes: empty, 1x1 and very wide images all work.

pub use crate::srgb::linear_to_srgb8;
use crate::srgb::unit;
use shadetrace_formats::atomic_file::write_bytes_atomically;
use std::path::Path;

use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use image::{ExtendedColorType, ImageEncoder};

/// Opaque black, the background wherever an output has no source pixel.
const BLACK: [u8; 4] = [0, 0, 0, 255];
/// Legend text and tick colour.
const WHITE: [u8; 4] = [255, 255, 255, 255];

/// An 8-bit sRGB image with straight (not premultiplied) alpha, row-major, top row first.
///
/// The fields are public so renderers can fill `pixels` directly; every function here
/// tolerates a `pixels` vector whose length is not `width * height` (missing pixels read
/// as absent, extra ones are ignored) except PNG encoding, which reports it as an error.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Rgba8Image {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<[u8; 4]>,
}

impl Rgba8Image {
    /// An opaque black image (black rather than transparent, so unrendered areas look
    /// like an empty frame in any viewer).
    pub fn new(width: u32, height: u32) -> Self {
        Self::filled(width, height, BLACK)
    }

    /// An image with every pixel set to `pixel`.
    pub fn filled(width: u32, height: u32, pixel: [u8; 4]) -> Self {
        let len = (width as usize).saturating_mul(height as usize);
        Self {
            width,
            height,
            pixels: vec![pixel; len],
        }
    }

    fn index(&self, x: u32, y: u32) -> Option<usize> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let i = (y as usize).checked_mul(self.width as usize)?.checked_add(x as usize)?;
        (i < self.pixels.len()).then_some(i)
    }

    /// The pixel at (`x`, `y`), or None outside the image.
    pub fn get(&self, x: u32, y: u32) -> Option<[u8; 4]> {
        self.index(x, y).map(|i| self.pixels[i])
    }

    /// Sets the pixel at (`x`, `y`); returns false (and changes nothing) outside the image,
    /// so drawing code can clip by simply ignoring the result.
    pub fn set(&mut self, x: u32, y: u32, pixel: [u8; 4]) -> bool {
        match self.index(x, y) {
            Some(i) => {
                self.pixels[i] = pixel;
                true
            }
            None => false,
        }
    }

    /// Copies `src` with its top-left corner at (`x0`, `y0`), clipped to this image.
    fn blit(&mut self, src: &Rgba8Image, x0: u32, y0: u32) {
        if x0 >= self.width {
            return;
        }
        let cols = src.width.min(self.width - x0) as usize;
        for y in 0..src.height.min(self.height.saturating_sub(y0)) {
            let (Some(s), Some(d)) = (src.index(0, y), self.index(x0, y0 + y)) else {
                continue;
            };
            let n = cols.min(src.pixels.len() - s).min(self.pixels.len() - d);
            self.pixels[d..d + n].copy_from_slice(&src.pixels[s..s + n]);
        }
    }

    /// Encodes the image as an 8-bit RGBA PNG.
    ///
    /// The compression level and filter are fixed explicitly rather than left to the
    /// encoder's defaults, so the bytes depend only on the pixels. Errors when `pixels`
    /// does not hold exactly `width * height` entries or the size cannot be a PNG (a zero
    /// dimension, or one above the PNG limit of 2^31 - 1).
    pub fn to_png_bytes(&self) -> Result<Vec<u8>, String> {
        let expected = (self.width as usize).checked_mul(self.height as usize);
        if expected != Some(self.pixels.len()) {
            return Err(format!(
                "image of {}x{} has {} pixels, not width * height",
                self.width,
                self.height,
                self.pixels.len()
            ));
        }
        let mut bytes = Vec::new();
        PngEncoder::new_with_quality(&mut bytes, CompressionType::Default, FilterType::Adaptive)
            .write_image(
                self.pixels.as_flattened(),
                self.width,
                self.height,
                ExtendedColorType::Rgba8,
            )
            .map_err(|e| format!("cannot encode a {}x{} PNG: {e}", self.width, self.height))?;
        Ok(bytes)
    }

    /// The image as a JPEG at `quality` (1-100), alpha dropped: for thumbnails, where PNG's
    /// exactness costs five times the bytes.
    pub fn to_jpeg_bytes(&self, quality: u8) -> Result<Vec<u8>, String> {
        let rgb: Vec<u8> = self.pixels.iter().flat_map(|p| [p[0], p[1], p[2]]).collect();
        let mut bytes = Vec::new();
        image::codecs::jpeg::JpegEncoder::new_with_quality(&mut bytes, quality)
            .write_image(&rgb, self.width, self.height, ExtendedColorType::Rgb8)
            .map_err(|e| e.to_string())?;
        Ok(bytes)
    }

    /// Writes the image as a PNG at `path`, atomically: the PNG is written to a temporary
    /// file in the same directory, flushed to disk and renamed over `path`, so a crash or
    /// an error never leaves a half-written PNG (and readers never see one).
    pub fn write_png(&self, path: impl AsRef<Path>) -> Result<(), String> {
        let path = path.as_ref();
        let bytes = self.to_png_bytes().map_err(|e| format!("{}: {e}", path.display()))?;
        write_bytes_atomically(path, &bytes)
    }
}

/// Converts linear RGBA (as rendered) to an 8-bit sRGB image. Colour goes through
/// [`linear_to_srgb8`]; alpha is coverage, not light, so it is only clamped and scaled.
/// `rgba` is read row-major; missing entries become transparent black and extra entries
/// are ignored, so a short buffer cannot panic (and stays visible as holes).
pub fn from_linear_rgba(width: u32, height: u32, rgba: &[[f32; 4]]) -> Rgba8Image {
    let mut image = Rgba8Image::filled(width, height, [0, 0, 0, 0]);
    for (out, &[r, g, b, a]) in image.pixels.iter_mut().zip(rgba) {
        let alpha = (unit(a) * 255.0).round() as u8;
        *out = [linear_to_srgb8(r), linear_to_srgb8(g), linear_to_srgb8(b), alpha];
    }
    image
}

/// A stereo pair as one picture: the left view on the left, the right view beside it
/// with no gap, top-aligned. A shorter view is padded with opaque black below. (Widths
/// whose sum exceeds `u32::MAX` are clipped, which no PNG could hold anyway.)
pub fn side_by_side(left: &Rgba8Image, right: &Rgba8Image) -> Rgba8Image {
    let mut out = Rgba8Image::new(left.width.saturating_add(right.width), left.height.max(right.height));
    out.blit(left, 0, 0);
    out.blit(right, left.width, 0);
    out
}

/// Height in pixels of the legend band that [`heat_map`] adds below the data.
pub const HEAT_MAP_LEGEND_HEIGHT: u32 = 24;
/// Legend glyphs are 3x5 cells drawn at this scale (6x10 pixels) to stay legible next to
/// full-resolution views.
const FONT_SCALE: u32 = 2;
/// Horizontal advance per character: the glyph plus one (scaled) column of spacing.
const GLYPH_ADVANCE: u32 = 4 * FONT_SCALE;
const LEGEND_MARGIN: u32 = 4;
const LEGEND_GAP: u32 = 8;

/// A colour-scale top that a few outliers cannot dominate: the 99th percentile of the
/// positive finite values (None when there are none). Per-pixel cost maps have rare
/// pixels shaded by dozens of groups (silhouettes, overdraw) that would otherwise leave the
/// rest of the map dark.
pub fn robust_max(values: impl Iterator<Item = f32>) -> Option<f32> {
    let mut v: Vec<f32> = values.filter(|x| x.is_finite() && *x > 0.0).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f32::total_cmp);
    Some(v[(v.len() - 1) * 99 / 100])
}

/// Top of the error pictures' scale, in 8-bit levels (larger errors saturate): fixed, so
/// error pictures compare across presets and frames.
pub const ERROR_SCALE: f32 = 32.0;
pub const ERROR_LABEL: &str = "max channel error vs reference";
/// Top of the SSIM-loss pictures' scale (`1 - SSIM` of each pixel's 11x11 window; larger
/// losses saturate), fixed for the same reason.
pub const SSIM_LOSS_SCALE: f32 = 0.1;
pub const SSIM_LOSS_LABEL: &str = "1 - local SSIM vs reference";

/// A false-colour picture of per-pixel values (shading cost, refinement level, SSIM, ...)
/// using the viridis colour map, which is perceptually uniform and readable by colour-blind
/// viewers, so equal steps in value look like equal steps in colour.
///
/// `values` is read row-major, `width * height` of them; missing values read as 0 and
/// extra ones are ignored. Values are scaled linearly from 0 (darkest) to `max`
/// (brightest) and clamped; NaN and negative values show as 0, +infinity as `max`. When
/// `max` is None, or is not a finite positive number, the largest finite value is used
/// (so a map of all zeros is uniformly dark). Pass an explicit `max` to make maps of
/// different frames or schemes comparable.
///
/// **The legend is part of the returned image**: a band of [`HEAT_MAP_LEGEND_HEIGHT`]
/// pixels below the data holds the colour bar with tick labels for 0 and the maximum and
/// `legend_label` between them (upper-cased: the embedded font has no lower case; other
/// unsupported characters print as '?'). The image is widened, with black on the right of
/// the data, when the legend text needs more room than `width`. So the result is
/// `max(width, legend width)` by `height + HEAT_MAP_LEGEND_HEIGHT`, with the data at the
/// top-left corner.
pub fn heat_map(values: &[f32], width: u32, height: u32, max: Option<f32>, legend_label: &str) -> Rgba8Image {
    let count = (width as usize).saturating_mul(height as usize);
    let data = &values[..values.len().min(count)];
    let data_max = data.iter().copied().filter(|v| v.is_finite()).fold(0.0f32, f32::max);
    let top = match max {
        Some(m) if m.is_finite() && m > 0.0 => m,
        _ => data_max,
    };
    let hi = format_tick(top);
    let legend_width = [
        2 * LEGEND_MARGIN,
        2 * LEGEND_GAP,
        text_width("0"),
        text_width(&hi),
        text_width(legend_label),
    ]
    .into_iter()
    .fold(0u32, u32::saturating_add);
    let mut out = Rgba8Image::new(width.max(legend_width), height.saturating_add(HEAT_MAP_LEGEND_HEIGHT));
    // `count` is 0 unless width > 0, so the modulo and division are safe.
    for i in 0..count {
        let v = data.get(i).copied().unwrap_or(0.0);
        let (x, y) = (i % width as usize, i / width as usize);
        out.set(x as u32, y as u32, viridis(colour_index(v, top)));
    }
    draw_legend(&mut out, height, &hi, legend_label);
    out
}

/// Position of `v` in the colour table for a scale of [0, `top`]; `top` is 0 or a
/// finite positive number.
fn colour_index(v: f32, top: f32) -> u8 {
    if top <= 0.0 || v.is_nan() {
        return 0;
    }
    ((v / top).clamp(0.0, 1.0) * 255.0).round() as u8
}

/// Tick label for the top of the scale: short plain decimals for everyday magnitudes,
/// scientific notation (`1.50e-3`) otherwise, so the label never grows unboundedly wide.
fn format_tick(v: f32) -> String {
    if v == 0.0 {
        "0".to_string()
    } else if (0.01..10_000.0).contains(&v) {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.2e}")
    }
}

/// Draws the legend into the band that starts at row `y0`. `out` is at least as wide as
/// the legend needs (see [`heat_map`]), so the pieces never overlap.
fn draw_legend(out: &mut Rgba8Image, y0: u32, hi: &str, label: &str) {
    let right = out.width - LEGEND_MARGIN;
    let bar_width = right - LEGEND_MARGIN;
    let bar_y = y0.saturating_add(3);
    for i in 0..bar_width {
        // Spread the 256 table entries evenly over the bar, both ends included.
        let index = if bar_width > 1 {
            (u64::from(i) * 255 + u64::from(bar_width - 1) / 2) / u64::from(bar_width - 1)
        } else {
            255
        };
        fill_rect(out, LEGEND_MARGIN + i, bar_y, 1, 6, viridis(index as u8));
    }
    // Ticks under both ends of the bar, above their labels.
    let tick_y = y0.saturating_add(9);
    fill_rect(out, LEGEND_MARGIN, tick_y, 1, 2, WHITE);
    fill_rect(out, right - 1, tick_y, 1, 2, WHITE);

    let text_y = y0.saturating_add(12);
    draw_text(out, LEGEND_MARGIN, text_y, "0");
    let hi_x = right.saturating_sub(text_width(hi));
    draw_text(out, hi_x, text_y, hi);
    // Centre the label, but keep it clear of both tick labels.
    let label_width = text_width(label);
    let earliest = LEGEND_MARGIN + text_width("0") + LEGEND_GAP;
    let latest = hi_x.saturating_sub(LEGEND_GAP.saturating_add(label_width));
    let centred = out.width.saturating_sub(label_width) / 2;
    draw_text(out, centred.clamp(earliest, latest.max(earliest)), text_y, label);
}

fn fill_rect(out: &mut Rgba8Image, x0: u32, y0: u32, width: u32, height: u32, pixel: [u8; 4]) {
    for y in (0..height).map_while(|dy| y0.checked_add(dy)) {
        for x in (0..width).map_while(|dx| x0.checked_add(dx)) {
            out.set(x, y, pixel);
        }
    }
}

fn text_width(text: &str) -> u32 {
    let chars = u32::try_from(text.chars().count()).unwrap_or(u32::MAX);
    chars.saturating_mul(GLYPH_ADVANCE).saturating_sub(FONT_SCALE)
}

fn draw_text(out: &mut Rgba8Image, x0: u32, y0: u32, text: &str) {
    for (i, c) in text.chars().enumerate() {
        let Some(gx) = u32::try_from(i)
            .ok()
            .and_then(|i| i.checked_mul(GLYPH_ADVANCE))
            .and_then(|dx| x0.checked_add(dx))
            .filter(|&gx| gx < out.width)
        else {
            break;
        };
        let bits = glyph(c);
        for row in 0..5 {
            for col in 0..3 {
                if (bits >> (14 - (row * 3 + col))) & 1 == 1 {
                    let x = gx.saturating_add(col * FONT_SCALE);
                    let y = y0.saturating_add(row * FONT_SCALE);
                    fill_rect(out, x, y, FONT_SCALE, FONT_SCALE, WHITE);
                }
            }
        }
    }
}

/// A 3x5 bitmap glyph: five rows of three bits, top row in the high bits, leftmost
/// column first. Enough for numbers in any `format!` notation and short upper-case
/// labels; lower case is drawn as upper case and anything else as '?'.
fn glyph(c: char) -> u16 {
    match c.to_ascii_uppercase() {
        ' ' => 0,
        '0' => 0b111_101_101_101_111,
        '1' => 0b010_110_010_010_111,
        '2' => 0b111_001_111_100_111,
        '3' => 0b111_001_111_001_111,
        '4' => 0b101_101_111_001_001,
        '5' => 0b111_100_111_001_111,
        '6' => 0b111_100_111_101_111,
        '7' => 0b111_001_001_001_001,
        '8' => 0b111_101_111_101_111,
        '9' => 0b111_101_111_001_111,
        'A' => 0b010_101_111_101_101,
        'B' => 0b110_101_110_101_110,
        'C' => 0b011_100_100_100_011,
        'D' => 0b110_101_101_101_110,
        'E' => 0b111_100_110_100_111,
        'F' => 0b111_100_110_100_100,
        'G' => 0b011_100_101_101_011,
        'H' => 0b101_101_111_101_101,
        'I' => 0b111_010_010_010_111,
        'J' => 0b001_001_001_101_010,
        'K' => 0b101_101_110_101_101,
        'L' => 0b100_100_100_100_111,
        'M' => 0b101_111_111_101_101,
        'N' => 0b111_101_101_101_101,
        'O' => 0b010_101_101_101_010,
        'P' => 0b110_101_110_100_100,
        'Q' => 0b010_101_101_110_011,
        'R' => 0b110_101_110_101_101,
        'S' => 0b011_100_010_001_110,
        'T' => 0b111_010_010_010_010,
        'U' => 0b101_101_101_101_111,
        'V' => 0b101_101_101_101_010,
        'W' => 0b101_101_111_111_101,
        'X' => 0b101_101_010_101_101,
        'Y' => 0b101_101_010_010_010,
        'Z' => 0b111_001_010_100_111,
        '.' => 0b000_000_000_000_010,
        ',' => 0b000_000_000_010_100,
        ':' => 0b000_010_000_010_000,
        '-' => 0b000_000_111_000_000,
        '+' => 0b000_010_111_010_000,
        '=' => 0b000_111_000_111_000,
        '_' => 0b000_000_000_000_111,
        '/' => 0b001_001_010_100_100,
        '%' => 0b101_001_010_100_101,
        '(' => 0b001_010_010_010_001,
        ')' => 0b100_010_010_010_100,
        '[' => 0b011_010_010_010_011,
        ']' => 0b110_010_010_010_110,
        '<' => 0b001_010_100_010_001,
        '>' => 0b100_010_001_010_100,
        _ => 0b111_001_010_000_010,
    }
}

/// The colour of table entry `index`.
fn viridis(index: u8) -> [u8; 4] {
    let i = usize::from(index) * 3;
    [VIRIDIS[i], VIRIDIS[i + 1], VIRIDIS[i + 2], 255]
}

/// Matplotlib's viridis colour map (van der Walt and Smith, CC0), 256 RGB entries
/// rounded to 8 bits, flattened as r, g, b, r, g, b, ...
#[rustfmt::skip]
const VIRIDIS: [u8; 768] = [
    68, 1, 84, 68, 2, 86, 69, 4, 87, 69, 5, 89, 70, 7, 90, 70, 8, 92, 70, 10, 93, 70, 11, 94,
    71, 13, 96, 71, 14, 97, 71, 16, 99, 71, 17, 100, 71, 19, 101, 72, 20, 103, 72, 22, 104, 72, 23, 105,
    72, 24, 106, 72, 26, 108, 72, 27, 109, 72, 28, 110, 72, 29, 111, 72, 31, 112, 72, 32, 113, 72, 33, 115,
    72, 35, 116, 72, 36, 117, 72, 37, 118, 72, 38, 119, 72, 40, 120, 72, 41, 121, 71, 42, 122, 71, 44, 122,
    71, 45, 123, 71, 46, 124, 71, 47, 125, 70, 48, 126, 70, 50, 126, 70, 51, 127, 70, 52, 128, 69, 53, 129,
    69, 55, 129, 69, 56, 130, 68, 57, 131, 68, 58, 131, 68, 59, 132, 67, 61, 132, 67, 62, 133, 66, 63, 133,
    66, 64, 134, 66, 65, 134, 65, 66, 135, 65, 68, 135, 64, 69, 136, 64, 70, 136, 63, 71, 136, 63, 72, 137,
    62, 73, 137, 62, 74, 137, 62, 76, 138, 61, 77, 138, 61, 78, 138, 60, 79, 138, 60, 80, 139, 59, 81, 139,
    59, 82, 139, 58, 83, 139, 58, 84, 140, 57, 85, 140, 57, 86, 140, 56, 88, 140, 56, 89, 140, 55, 90, 140,
    55, 91, 141, 54, 92, 141, 54, 93, 141, 53, 94, 141, 53, 95, 141, 52, 96, 141, 52, 97, 141, 51, 98, 141,
    51, 99, 141, 50, 100, 142, 50, 101, 142, 49, 102, 142, 49, 103, 142, 49, 104, 142, 48, 105, 142, 48, 106, 142,
    47, 107, 142, 47, 108, 142, 46, 109, 142, 46, 110, 142, 46, 111, 142, 45, 112, 142, 45, 113, 142, 44, 113, 142,
    44, 114, 142, 44, 115, 142, 43, 116, 142, 43, 117, 142, 42, 118, 142, 42, 119, 142, 42, 120, 142, 41, 121, 142,
    41, 122, 142, 41, 123, 142, 40, 124, 142, 40, 125, 142, 39, 126, 142, 39, 127, 142, 39, 128, 142, 38, 129, 142,
    38, 130, 142, 38, 130, 142, 37, 131, 142, 37, 132, 142, 37, 133, 142, 36, 134, 142, 36, 135, 142, 35, 136, 142,
    35, 137, 142, 35, 138, 141, 34, 139, 141, 34, 140, 141, 34, 141, 141, 33, 142, 141, 33, 143, 141, 33, 144, 141,
    33, 145, 140, 32, 146, 140, 32, 146, 140, 32, 147, 140, 31, 148, 140, 31, 149, 139, 31, 150, 139, 31, 151, 139,
    31, 152, 139, 31, 153, 138, 31, 154, 138, 30, 155, 138, 30, 156, 137, 30, 157, 137, 31, 158, 137, 31, 159, 136,
    31, 160, 136, 31, 161, 136, 31, 161, 135, 31, 162, 135, 32, 163, 134, 32, 164, 134, 33, 165, 133, 33, 166, 133,
    34, 167, 133, 34, 168, 132, 35, 169, 131, 36, 170, 131, 37, 171, 130, 37, 172, 130, 38, 173, 129, 39, 173, 129,
    40, 174, 128, 41, 175, 127, 42, 176, 127, 44, 177, 126, 45, 178, 125, 46, 179, 124, 47, 180, 124, 49, 181, 123,
    50, 182, 122, 52, 182, 121, 53, 183, 121, 55, 184, 120, 56, 185, 119, 58, 186, 118, 59, 187, 117, 61, 188, 116,
    63, 188, 115, 64, 189, 114, 66, 190, 113, 68, 191, 112, 70, 192, 111, 72, 193, 110, 74, 193, 109, 76, 194, 108,
    78, 195, 107, 80, 196, 106, 82, 197, 105, 84, 197, 104, 86, 198, 103, 88, 199, 101, 90, 200, 100, 92, 200, 99,
    94, 201, 98, 96, 202, 96, 99, 203, 95, 101, 203, 94, 103, 204, 92, 105, 205, 91, 108, 205, 90, 110, 206, 88,
    112, 207, 87, 115, 208, 86, 117, 208, 84, 119, 209, 83, 122, 209, 81, 124, 210, 80, 127, 211, 78, 129, 211, 77,
    132, 212, 75, 134, 213, 73, 137, 213, 72, 139, 214, 70, 142, 214, 69, 144, 215, 67, 147, 215, 65, 149, 216, 64,
    152, 216, 62, 155, 217, 60, 157, 217, 59, 160, 218, 57, 162, 218, 55, 165, 219, 54, 168, 219, 52, 170, 220, 50,
    173, 220, 48, 176, 221, 47, 178, 221, 45, 181, 222, 43, 184, 222, 41, 186, 222, 40, 189, 223, 38, 192, 223, 37,
    194, 223, 35, 197, 224, 33, 200, 224, 32, 202, 225, 31, 205, 225, 29, 208, 225, 28, 210, 226, 27, 213, 226, 26,
    216, 226, 25, 218, 227, 25, 221, 227, 24, 223, 227, 24, 226, 228, 24, 229, 228, 25, 231, 228, 25, 234, 229, 26,
    236, 229, 27, 239, 229, 28, 241, 229, 29, 244, 230, 30, 246, 230, 32, 248, 230, 33, 251, 231, 35, 253, 231, 37,
];

#[cfg(test)]
mod robust_max_tests {
    use super::robust_max;

    #[test]
    fn outliers_do_not_set_the_scale() {
        let mut v: Vec<f32> = (1..=1000).map(|x| x as f32).collect();
        v.push(1e9);
        assert_eq!(robust_max(v.into_iter()), Some(991.0));
        assert_eq!(robust_max([0.0, f32::NAN, -1.0].into_iter()), None);
        assert_eq!(robust_max([5.0].into_iter()), Some(5.0));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// First table entry with this colour (viridis repeats two adjacent entries).
    fn table_index(p: [u8; 4]) -> Option<u8> {
        (0..=255u8).find(|&i| viridis(i) == p)
    }

    fn sample(width: u32, height: u32) -> Rgba8Image {
        let mut img = Rgba8Image::new(width, height);
        for y in 0..height {
            for x in 0..width {
                img.set(
                    x,
                    y,
                    [(x * 37) as u8, (y * 53) as u8, (x * y) as u8, (255 - x * 11) as u8],
                );
            }
        }
        img
    }

    #[test]
    fn get_and_set_clip_to_the_image() {
        let mut img = Rgba8Image::new(3, 2);
        assert!(img.set(2, 1, [1, 2, 3, 4]));
        assert_eq!(img.get(2, 1), Some([1, 2, 3, 4]));
        assert_eq!(img.get(0, 0), Some(BLACK));
        assert!(!img.set(3, 0, WHITE));
        assert_eq!(img.get(0, 2), None);
        img.pixels.truncate(2);
        assert_eq!(img.get(2, 1), None);
    }

    #[test]
    fn png_round_trip_is_lossless_and_deterministic() {
        let img = sample(7, 5);
        let bytes = img.to_png_bytes().unwrap();
        assert_eq!(bytes, img.to_png_bytes().unwrap());
        let decoded = image::load_from_memory_with_format(&bytes, image::ImageFormat::Png)
            .unwrap()
            .to_rgba8();
        assert_eq!((decoded.width(), decoded.height()), (7, 5));
        assert_eq!(decoded.as_raw().as_slice(), img.pixels.as_flattened());
    }

    #[test]
    fn png_rejects_what_it_cannot_encode() {
        assert!(Rgba8Image::new(0, 0).to_png_bytes().is_err());
        assert!(Rgba8Image::new(0, 4).to_png_bytes().is_err());
        let mut short = Rgba8Image::new(2, 2);
        short.pixels.pop();
        assert!(short.to_png_bytes().is_err());
    }

    #[test]
    fn write_png_leaves_only_the_finished_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("view.png");
        let img = sample(4, 3);
        img.write_png(&path).unwrap();
        img.write_png(&path).unwrap();
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, ["view.png"]);
        assert_eq!(std::fs::read(&path).unwrap(), img.to_png_bytes().unwrap());

        assert!(Rgba8Image::new(0, 0).write_png(dir.path().join("empty.png")).is_err());
        assert!(img.write_png(dir.path().join("missing/view.png")).is_err());
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(names.len(), 1, "a failed write leaves nothing behind");
    }

    #[test]
    fn srgb_encoding() {
        assert_eq!(linear_to_srgb8(0.0), 0);
        assert_eq!(linear_to_srgb8(1.0), 255);
        assert_eq!(linear_to_srgb8(0.5), 188);
        assert_eq!(linear_to_srgb8(0.001), 3);
        assert_eq!(linear_to_srgb8(f32::NAN), 0);
        assert_eq!(linear_to_srgb8(-2.0), 0);
        assert_eq!(linear_to_srgb8(7.0), 255);
        assert_eq!(linear_to_srgb8(f32::INFINITY), 255);
        let codes: Vec<u8> = (0..=1000).map(|i| linear_to_srgb8(i as f32 / 1000.0)).collect();
        assert!(codes.windows(2).all(|w| w[0] <= w[1]));
    }

    #[test]
    fn linear_rgba_conversion() {
        let img = from_linear_rgba(2, 2, &[[1.0, 0.0, 0.5, 0.5], [0.0, 1.0, f32::NAN, 2.0], [0.0; 4]]);
        assert_eq!(
            img.pixels,
            [[255, 0, 188, 128], [0, 255, 0, 255], [0, 0, 0, 0], [0, 0, 0, 0]]
        );
    }

    #[test]
    fn stereo_pair_places_left_then_right() {
        let left = Rgba8Image::filled(2, 3, [1, 1, 1, 255]);
        let right = Rgba8Image::filled(3, 2, [2, 2, 2, 255]);
        let pair = side_by_side(&left, &right);
        assert_eq!((pair.width, pair.height), (5, 3));
        assert_eq!(pair.get(1, 2), Some([1, 1, 1, 255]));
        assert_eq!(pair.get(2, 0), Some([2, 2, 2, 255]));
        assert_eq!(pair.get(4, 1), Some([2, 2, 2, 255]));
        assert_eq!(pair.get(4, 2), Some(BLACK));
        let empty = side_by_side(&Rgba8Image::new(0, 0), &Rgba8Image::new(0, 5));
        assert_eq!((empty.width, empty.height, empty.pixels.len()), (0, 5, 0));
    }

    #[test]
    fn heat_map_of_a_ramp_is_monotone_and_spans_the_table() {
        let values: Vec<f32> = (0..300).map(|i| i as f32 * 0.5).collect();
        let map = heat_map(&values, 300, 1, None, "cost");
        let indices: Vec<u8> = (0..300).map(|x| table_index(map.get(x, 0).unwrap()).unwrap()).collect();
        assert!(indices.windows(2).all(|w| w[0] <= w[1]));
        assert_eq!((indices[0], indices[299]), (0, 255));
    }

    #[test]
    fn heat_map_has_a_legend_below_the_data() {
        let map = heat_map(&[1.0; 128 * 48], 128, 48, Some(4.0), "instr/px");
        assert_eq!((map.width, map.height), (128, 48 + HEAT_MAP_LEGEND_HEIGHT));
        assert_eq!(map.get(10, 10), Some(viridis(64)));
        let band: Vec<[u8; 4]> = (48..map.height)
            .flat_map(|y| (0..map.width).map(move |x| (x, y)))
            .map(|(x, y)| map.get(x, y).unwrap())
            .collect();
        assert!(band.contains(&viridis(0)) && band.contains(&viridis(255)), "colour bar");
        assert!(band.contains(&WHITE), "tick labels");
    }

    #[test]
    fn heat_map_survives_degenerate_input() {
        let one = heat_map(&[3.0], 1, 1, None, "");
        assert_eq!(one.height, 1 + HEAT_MAP_LEGEND_HEIGHT);
        assert!(one.width > 1, "widened to fit the legend");
        assert_eq!(one.get(0, 0), Some(viridis(255)));
        assert_eq!(one.get(1, 0), Some(BLACK));

        let zeros = heat_map(&[0.0; 12], 4, 3, None, "zero");
        assert!((0..12).all(|i| zeros.get(i % 4, i / 4) == Some(viridis(0))));

        let odd = heat_map(
            &[f32::NAN, -1.0, f32::INFINITY, 2.0],
            2,
            2,
            Some(f32::NAN),
            "odd values",
        );
        let row: Vec<_> = [(0, 0), (1, 0), (0, 1), (1, 1)]
            .iter()
            .map(|&(x, y)| odd.get(x, y).unwrap())
            .collect();
        assert_eq!(row, [viridis(0), viridis(0), viridis(255), viridis(255)]);

        let short = heat_map(&[1.0], 3, 3, None, "short");
        assert_eq!(short.get(2, 2), Some(viridis(0)));
        let empty = heat_map(&[], 0, 0, None, "");
        assert_eq!(empty.height, HEAT_MAP_LEGEND_HEIGHT);
        let wide = heat_map(&[1.0; 200_000], 200_000, 1, Some(2.0), "wide \u{e9}\u{1F600}");
        assert_eq!(wide.width, 200_000);
        assert_eq!(wide.get(199_999, 0), Some(viridis(128)));
    }

    #[test]
    fn tick_labels_stay_short() {
        assert_eq!(format_tick(0.0), "0");
        assert_eq!(format_tick(12.5), "12.5");
        assert_eq!(format_tick(3.0), "3");
        assert_eq!(format_tick(0.125), "0.125");
        assert_eq!(format_tick(0.001), "1.00e-3");
        assert_eq!(format_tick(2.5e7), "2.50e7");
        assert!(format_tick(f32::MAX).len() <= 8);
    }
}
