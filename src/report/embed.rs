//! Pictures inside the report: PNG or JPEG bytes as `data:` URIs (so the HTML needs no
//! other file) and the nearest-neighbour downscaling of its thumbnails.

use shadetrace_replay::images::Rgba8Image;

/// A heat map thumbnail as a PNG `data:` URI: RGB (the maps are opaque) at the best
/// compression, which keeps the page about a sixth smaller than default RGBA PNGs.
pub fn png_data_uri(image: &Rgba8Image) -> Result<String, String> {
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    use image::{ExtendedColorType, ImageEncoder};
    let rgb: Vec<u8> = image.pixels.iter().flat_map(|p| [p[0], p[1], p[2]]).collect();
    let mut png = Vec::new();
    PngEncoder::new_with_quality(&mut png, CompressionType::Best, FilterType::Adaptive)
        .write_image(&rgb, image.width, image.height, ExtendedColorType::Rgb8)
        .map_err(|e| format!("encoding a thumbnail: {e}"))?;
    Ok(data_uri("image/png", &png))
}

/// JPEG quality of the rendered views' thumbnails: a fifth of their PNG size, which keeps a
/// report of many presets and scenes small (heat maps, with their flat colours and legend,
/// stay PNG: smaller so).
const THUMBNAIL_JPEG_QUALITY: u8 = 80;

/// An image as a JPEG `data:` URI (alpha dropped).
pub fn jpeg_data_uri(image: &Rgba8Image) -> Result<String, String> {
    Ok(data_uri("image/jpeg", &image.to_jpeg_bytes(THUMBNAIL_JPEG_QUALITY)?))
}

fn data_uri(media_type: &str, bytes: &[u8]) -> String {
    use base64::Engine;
    format!(
        "data:{media_type};base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    )
}

/// The size of a `width` x `height` view scaled down (aspect kept) to at most `max_width`
/// pixels wide; views already narrow enough keep their size.
pub fn fit_width(width: u32, height: u32, max_width: u32) -> (u32, u32) {
    if width <= max_width || max_width == 0 {
        return (width, height);
    }
    let scaled = (u64::from(height) * u64::from(max_width)).div_ceil(u64::from(width));
    (max_width, u32::try_from(scaled).unwrap_or(u32::MAX).max(1))
}

/// Nearest-neighbour resampling of a row-major grid: each output cell takes the source
/// cell under its top-left corner. Missing source cells read as `fill`, so a short buffer
/// cannot panic. Nearest (not filtered) so heat-map values stay real measured values.
pub fn resample<T: Copy>(src: &[T], width: u32, height: u32, to: (u32, u32), fill: T) -> Vec<T> {
    let (tw, th) = to;
    let mut out = Vec::with_capacity(tw as usize * th as usize);
    for y in 0..u64::from(th) {
        let sy = y * u64::from(height) / u64::from(th);
        for x in 0..u64::from(tw) {
            let sx = x * u64::from(width) / u64::from(tw);
            let i = sy * u64::from(width) + sx;
            out.push(
                usize::try_from(i)
                    .ok()
                    .and_then(|i| src.get(i))
                    .copied()
                    .unwrap_or(fill),
            );
        }
    }
    out
}

/// `image` scaled down to at most `max_width` pixels wide (unchanged when narrower).
pub fn downscale(image: &Rgba8Image, max_width: u32) -> Rgba8Image {
    let to = fit_width(image.width, image.height, max_width);
    if to == (image.width, image.height) {
        return image.clone();
    }
    Rgba8Image {
        width: to.0,
        height: to.1,
        pixels: resample(&image.pixels, image.width, image.height, to, [0, 0, 0, 255]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_uris_carry_standard_base64() {
        assert_eq!(data_uri("image/png", b"foob"), "data:image/png;base64,Zm9vYg==");
    }

    #[test]
    fn heat_map_thumbnails_are_rgb_pngs_of_the_same_pixels() {
        use base64::Engine;
        let mut image = Rgba8Image::new(3, 2);
        image.pixels[4] = [10, 200, 30, 255];
        let uri = png_data_uri(&image).unwrap();
        let png = base64::engine::general_purpose::STANDARD
            .decode(uri.strip_prefix("data:image/png;base64,").unwrap())
            .unwrap();
        let decoded = image::load_from_memory(&png).unwrap();
        assert_eq!(decoded.color(), image::ColorType::Rgb8);
        assert_eq!(decoded.to_rgb8().get_pixel(1, 1).0, [10, 200, 30]);
    }

    #[test]
    fn downscaling_keeps_aspect_and_picks_nearest() {
        assert_eq!(fit_width(1280, 1440, 640), (640, 720));
        assert_eq!(fit_width(500, 300, 640), (500, 300));
        assert_eq!(fit_width(10_000, 1, 640), (640, 1));
        let src: Vec<u32> = (0..16).collect();
        assert_eq!(resample(&src, 4, 4, (2, 2), 99), [0, 2, 8, 10]);
        assert_eq!(resample(&src[..3], 4, 4, (2, 2), 99), [0, 2, 99, 99]);
        let img = Rgba8Image::filled(1280, 4, [1, 2, 3, 255]);
        let small = downscale(&img, 640);
        assert_eq!((small.width, small.height, small.pixels.len()), (640, 2, 1280));
    }
}
