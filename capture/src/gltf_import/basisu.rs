//! `KHR_texture_basisu`: KTX2 images supercompressed with Basis Universal (ETC1S/BasisLZ
//! or UASTC, optionally Zstandard), transcoded to RGBA8 by the `basisu` crate, a pure-Rust
//! port of Basis Universal's transcoder that matches it byte for byte.

use basisu::{DecodeFlags, TargetFormat, Transcoder};
use image::RgbaImage;

/// The extension's name; its `source` names the KTX2 image of a texture.
pub(super) const EXTENSION: &str = "KHR_texture_basisu";

/// The 12-byte identifier every KTX2 file starts with.
const KTX2_IDENTIFIER: [u8; 12] = [
    0xAB, b'K', b'T', b'X', b' ', b'2', b'0', 0xBB, b'\r', b'\n', 0x1A, b'\n',
];

pub(super) fn is_ktx2(bytes: &[u8]) -> bool {
    bytes.starts_with(&KTX2_IDENTIFIER)
}

/// The largest mip level whose longer edge fits `max_edge` (the last level if none
/// does), as RGBA8, so a texture cap skips decoding the levels it would discard. Levels
/// whose RGBA8 form would exceed `max_bytes` are refused before anything is transcoded.
pub(super) fn decode(bytes: &[u8], max_edge: u32, max_bytes: u64) -> Result<RgbaImage, String> {
    let problem = |e: basisu::Error| format!("{e:?}");
    // The transcoder allocates each Zstandard level at the size its header declares:
    // bound that first (`ktx2` parses the container without allocating).
    let container = ktx2::Reader::new(bytes).map_err(|e| format!("not a KTX2 file ({e})"))?;
    if let Some(level) = container.levels().find(|l| l.uncompressed_byte_length > max_bytes) {
        return Err(format!(
            "a level declares {} uncompressed bytes, more than the {max_bytes} capture decodes",
            level.uncompressed_byte_length
        ));
    }
    let transcoder = Transcoder::new(bytes).map_err(|e| format!("not a Basis Universal KTX2 texture ({e:?})"))?;
    if transcoder.is_video() || transcoder.layer_count() > 1 || transcoder.face_count() > 1 {
        return Err("a video, array or cube-map KTX2 texture (glTF textures are 2D)".to_string());
    }
    let levels = transcoder.level_count();
    if levels == 0 {
        return Err("a KTX2 texture without levels".to_string());
    }
    let mut level = 0;
    while level + 1 < levels {
        let info = transcoder.image_level_info(level).map_err(problem)?;
        if info.width.max(info.height) <= max_edge {
            break;
        }
        level += 1;
    }
    let info = transcoder.image_level_info(level).map_err(problem)?;
    let rgba_bytes = u64::from(info.width) * u64::from(info.height) * 4;
    if info.width == 0 || info.height == 0 || rgba_bytes > max_bytes {
        return Err(format!(
            "level {level} is {}x{}: {rgba_bytes} bytes as RGBA, more than the {max_bytes} capture decodes",
            info.width, info.height
        ));
    }
    let rgba = transcoder
        .transcode(level, TargetFormat::Rgba32, DecodeFlags::NONE)
        .map_err(problem)?;
    RgbaImage::from_raw(info.width, info.height, rgba).ok_or_else(|| "transcoded level has the wrong size".to_string())
}
