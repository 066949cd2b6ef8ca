//! Pictures inside the report: PNG or JPEG bytes as `data:` URIs (so the HTML needs no
//! other file) and the nearest-neighbour downscaling of its thumbnails.

use shadetrace_replay::images::Rgba8Image;

/// A heat map thumbnail as a PNG `data:` URI at the best compression: indexed colour when
/// it has at most 256 colours (the heat maps' table, the legend's black and white: about
/// half the size of RGB), RGB otherwise (the maps are opaque).
pub fn png_data_uri(image: &Rgba8Image) -> Result<String, String> {
    let err = |e: png::EncodingError| format!("encoding a thumbnail: {e}");
    let mut bytes = Vec::new();
    let mut encoder = png::Encoder::new(&mut bytes, image.width, image.height);
    encoder.set_compression(png::Compression::High);
    encoder.set_depth(png::BitDepth::Eight);
    let data = match palette(image) {
        Some((colours, indices)) => {
            encoder.set_color(png::ColorType::Indexed);
            encoder.set_palette(colours);
            indices
        }
        None => {
            encoder.set_color(png::ColorType::Rgb);
            image.pixels.iter().flat_map(|p| [p[0], p[1], p[2]]).collect()
        }
    };
    let mut writer = encoder.write_header().map_err(err)?;
    writer.write_image_data(&data).map_err(err)?;
    writer.finish().map_err(err)?;
    Ok(data_uri("image/png", &bytes))
}

/// The image's colours (RGB, in order of first appearance) and each pixel's index, when
/// there are at most 256.
fn palette(image: &Rgba8Image) -> Option<(Vec<u8>, Vec<u8>)> {
    let mut colours: Vec<[u8; 3]> = Vec::new();
    let mut index_of: std::collections::HashMap<[u8; 3], u8> = std::collections::HashMap::new();
    let mut indices = Vec::with_capacity(image.pixels.len());
    for p in &image.pixels {
        let rgb = [p[0], p[1], p[2]];
        let i = match index_of.get(&rgb) {
            Some(&i) => i,
            None => {
                let i = u8::try_from(colours.len()).ok()?;
                colours.push(rgb);
                index_of.insert(rgb, i);
                i
            }
        };
        indices.push(i);
    }
    Some((colours.concat(), indices))
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

    fn decode(uri: &str) -> image::DynamicImage {
        use base64::Engine;
        let png = base64::engine::general_purpose::STANDARD
            .decode(uri.strip_prefix("data:image/png;base64,").unwrap())
            .unwrap();
        image::load_from_memory(&png).unwrap()
    }

    #[test]
    fn heat_map_thumbnails_are_pngs_of_the_same_pixels() {
        // Few colours: indexed.
        let mut image = Rgba8Image::new(3, 2);
        image.pixels[4] = [10, 200, 30, 255];
        let uri = png_data_uri(&image).unwrap();
        assert!(palette(&image).is_some_and(|(colours, _)| colours.len() == 2 * 3));
        assert_eq!(decode(&uri).to_rgb8().get_pixel(1, 1).0, [10, 200, 30]);
        // More than 256 colours: RGB, the same pixels.
        let mut many = Rgba8Image::new(300, 1);
        for (i, p) in many.pixels.iter_mut().enumerate() {
            *p = [(i % 256) as u8, (i / 256) as u8, 7, 255];
        }
        assert!(palette(&many).is_none());
        let decoded = decode(&png_data_uri(&many).unwrap());
        assert_eq!(decoded.color(), image::ColorType::Rgb8);
        assert_eq!(decoded.to_rgb8().get_pixel(299, 0).0, [43, 1, 7]);
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
