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

/// Bytes from the start of a KTX2 file to its level index (the header and the index of
/// its other sections), and the size of one level's entry (offset, length, uncompressed
/// length, each a u64).
const LEVEL_INDEX_AT: usize = 80;
const LEVEL_ENTRY_LEN: usize = 24;

/// Each level's declared uncompressed size, from the KTX2 level index (its fixed layout:
/// the level count is the u32 at byte 40, 0 meaning one level).
fn declared_level_sizes(bytes: &[u8]) -> Option<Vec<u64>> {
    let u32_at = |at: usize| Some(u32::from_le_bytes(*bytes.get(at..)?.first_chunk::<4>()?));
    let u64_at = |at: usize| Some(u64::from_le_bytes(*bytes.get(at..)?.first_chunk::<8>()?));
    let levels = u32_at(40)?.max(1) as usize;
    (0..levels)
        .map(|i| u64_at(LEVEL_INDEX_AT + i * LEVEL_ENTRY_LEN + 16))
        .collect()
}

/// The largest mip level whose longer edge fits `max_edge` (the last level if none
/// does), as RGBA8, so a texture cap skips decoding the levels it would discard. Levels
/// whose RGBA8 form would exceed `max_bytes` are refused before anything is transcoded.
pub(super) fn decode(bytes: &[u8], max_edge: u32, max_bytes: u64) -> Result<RgbaImage, String> {
    // The transcoder allocates each Zstandard level at the size its header declares:
    // bound that first. (The `ktx2` crate, tried for this, panics on corrupt files.)
    let sizes = declared_level_sizes(bytes).ok_or_else(|| "a truncated KTX2 level index".to_string())?;
    if let Some(size) = sizes.iter().find(|&&size| size > max_bytes) {
        return Err(format!(
            "a level declares {size} uncompressed bytes, more than the {max_bytes} capture decodes"
        ));
    }
    // The transcoder is young and reads what users share: a panic is an error too.
    crate::contained::contain(|| transcode(bytes, max_edge, max_bytes))
        .map_err(|panic| format!("the Basis transcoder failed: {panic}"))?
}

fn transcode(bytes: &[u8], max_edge: u32, max_bytes: u64) -> Result<RgbaImage, String> {
    let problem = |e: basisu::Error| format!("{e:?}");
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn level_sizes_come_from_the_level_index_and_truncation_is_refused() {
        let mut ktx2 = KTX2_IDENTIFIER.to_vec();
        ktx2.resize(LEVEL_INDEX_AT + 2 * LEVEL_ENTRY_LEN, 0);
        ktx2[40..44].copy_from_slice(&2u32.to_le_bytes());
        ktx2[LEVEL_INDEX_AT + 16..][..8].copy_from_slice(&1000u64.to_le_bytes());
        ktx2[LEVEL_INDEX_AT + LEVEL_ENTRY_LEN + 16..][..8].copy_from_slice(&(1u64 << 40).to_le_bytes());
        assert_eq!(declared_level_sizes(&ktx2), Some(vec![1000, 1 << 40]));
        assert!(decode(&ktx2, 2048, 256 << 20).unwrap_err().contains("declares"));
        assert_eq!(declared_level_sizes(&ktx2[..LEVEL_INDEX_AT + 30]), None);
    }
}
