//! `EXT_meshopt_compression` / `KHR_meshopt_compression`: buffer views stored in
//! meshoptimizer's vertex and index codecs (what gltfpack writes), decoded by the
//! `meshopt` crate (meshoptimizer's own C++ decoders, safe on untrusted input).
//!
//! A compressed view names its compressed bytes in another buffer; the view's own
//! buffer is then usually a *fallback* without data. The decoded bytes replace the view's
//! bytes, so accessors read them like any other view.

use std::collections::HashMap;

use gltf::json;
use serde::Deserialize;

use super::budget::GeometryBudget;
use super::{input, Fallible};

/// The extension names this module decodes: the vendor extension and its ratified
/// successor share one format.
pub(super) const EXTENSIONS: [&str; 2] = ["EXT_meshopt_compression", "KHR_meshopt_compression"];

/// One compressed buffer view, as the extension object describes it.
#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct Compressed {
    buffer: u32,
    #[serde(default)]
    byte_offset: u64,
    byte_length: u64,
    byte_stride: u64,
    count: u64,
    mode: Mode,
    #[serde(default)]
    filter: Filter,
}

#[derive(Clone, Copy, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
enum Mode {
    Attributes,
    Triangles,
    Indices,
}

#[derive(Clone, Copy, Default, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
enum Filter {
    #[default]
    None,
    Octahedral,
    Quaternion,
    Exponential,
    Color,
}

/// Whether a buffer is only a placeholder for data that compressed views decode into.
pub(super) fn is_fallback(buffer: &json::Buffer) -> bool {
    let Some(ext) = &buffer.extensions else { return false };
    EXTENSIONS.iter().any(|name| {
        ext.others
            .get(*name)
            .and_then(|e| e.get("fallback"))
            .and_then(json::Value::as_bool)
            .unwrap_or(false)
    })
}

/// Decodes every compressed buffer view. `buffers` are the loaded buffers (fallbacks
/// empty); each view's decoded bytes are charged to `budget` before they are allocated.
pub(super) fn decode_views(
    root: &json::Root,
    buffers: &[Vec<u8>],
    budget: &GeometryBudget,
) -> Fallible<HashMap<usize, Vec<u8>>> {
    let mut decoded = HashMap::new();
    for (v, view) in root.buffer_views.iter().enumerate() {
        let Some(ext) = view
            .extensions
            .as_ref()
            .and_then(|e| EXTENSIONS.iter().find_map(|n| e.others.get(*n)))
        else {
            continue;
        };
        let what = format!("buffer view {v} (meshopt compression)");
        let c: Compressed = json::deserialize::from_value(ext.clone()).map_err(|e| input(format!("{what}: {e}")))?;
        if c.count.checked_mul(c.byte_stride) != Some(view.byte_length.0) {
            return Err(input(format!(
                "{what}: count {} x byteStride {} is not the view's byteLength {}",
                c.count, c.byte_stride, view.byte_length.0
            )));
        }
        budget.charge(c.count, c.byte_stride, &what)?;
        let source = buffers
            .get(c.buffer as usize)
            .and_then(|b| {
                let start = usize::try_from(c.byte_offset).ok()?;
                b.get(start..start.checked_add(usize::try_from(c.byte_length).ok()?)?)
            })
            .ok_or_else(|| {
                input(format!(
                    "{what}: bytes {}..+{} are not in buffer {}",
                    c.byte_offset, c.byte_length, c.buffer
                ))
            })?;
        let bytes = decode(&c, source).map_err(|problem| input(format!("{what}: {problem}")))?;
        decoded.insert(v, bytes);
    }
    Ok(decoded)
}

/// One view's bytes, `count * byte_stride` of them.
fn decode(c: &Compressed, source: &[u8]) -> Result<Vec<u8>, String> {
    let count = usize::try_from(c.count).map_err(|_| "count too large".to_string())?;
    let stride = usize::try_from(c.byte_stride).map_err(|_| "byteStride too large".to_string())?;
    let corrupt = |e: meshopt::Error| format!("corrupt compressed data ({e})");
    match c.mode {
        Mode::Attributes => {
            if stride == 0 || stride % 4 != 0 || stride > 256 {
                return Err(format!(
                    "ATTRIBUTES byteStride {stride} is not a multiple of 4 up to 256"
                ));
            }
            let filter_ok = match c.filter {
                Filter::None | Filter::Exponential => true,
                Filter::Octahedral | Filter::Color => stride == 4 || stride == 8,
                Filter::Quaternion => stride == 8,
            };
            if !filter_ok {
                return Err(format!("its filter does not allow byteStride {stride}"));
            }
            let mut words = vec![0u32; count * stride / 4];
            // SAFETY: `words` holds `count * stride` bytes, 4-byte aligned, which is what
            // the decoder writes and what the filters (8- and 16-bit lanes) read and write
            // in place; `source` is a live slice of `source.len()` bytes.
            let status = unsafe {
                let out = words.as_mut_ptr().cast::<std::ffi::c_void>();
                let status =
                    meshopt::ffi::meshopt_decodeVertexBuffer(out, count, stride, source.as_ptr(), source.len());
                if status == 0 {
                    match c.filter {
                        Filter::None => {}
                        Filter::Octahedral => meshopt::ffi::meshopt_decodeFilterOct(out, count, stride),
                        Filter::Quaternion => meshopt::ffi::meshopt_decodeFilterQuat(out, count, stride),
                        Filter::Exponential => meshopt::ffi::meshopt_decodeFilterExp(out, count, stride),
                        Filter::Color => meshopt::ffi::meshopt_decodeFilterColor(out, count, stride),
                    }
                }
                status
            };
            if status != 0 {
                return Err(format!("corrupt compressed vertex data (meshopt error {status})"));
            }
            Ok(words.iter().flat_map(|w| w.to_ne_bytes()).collect())
        }
        Mode::Triangles | Mode::Indices => {
            if !matches!(c.filter, Filter::None) {
                return Err("index data cannot have a filter".to_string());
            }
            let triangles = matches!(c.mode, Mode::Triangles);
            if triangles && count % 3 != 0 {
                return Err(format!("TRIANGLES count {count} is not a multiple of 3"));
            }
            if stride != 2 && stride != 4 {
                return Err(format!("index byteStride {stride} is neither 2 nor 4"));
            }
            // The codecs do not depend on the output width (meshoptimizer narrows each
            // index when it writes 16 bits): decode 32-bit, then write `stride` bytes each.
            let indices: Vec<u32> = if triangles {
                meshopt::decode_index_buffer(source, count)
            } else {
                meshopt::decode_index_sequence(source, count)
            }
            .map_err(corrupt)?;
            Ok(indices
                .iter()
                .flat_map(|i| i.to_le_bytes().into_iter().take(stride))
                .collect())
        }
    }
}
