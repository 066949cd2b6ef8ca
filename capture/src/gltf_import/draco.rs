//! `KHR_draco_mesh_compression`: primitives whose indices and attributes are one Draco
//! bitstream in a buffer view, decoded by `draco-oxide-decoder` (a pure-Rust Draco
//! decoder for bitstream 2.2, what Google's encoder and gltf-transform write).
//!
//! Per the extension, the primitive's accessors still describe the decoded data (count,
//! type, component type, normalization); they just have no bytes. Decoding writes each
//! one's elements, tightly packed in its component type, so that accessor reads take
//! them like any other.

use std::collections::{BTreeMap, HashMap};

use draco_oxide_core::attribute::{Attribute, ComponentDataType};
use draco_oxide_core::types::PointIdx;
use gltf::json::{self, accessor::ComponentType, validation::Checked};
use serde::Deserialize;

use super::{input, valid, Fallible};

pub(super) const EXTENSION: &str = "KHR_draco_mesh_compression";

/// The extension object of a primitive.
#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct Compressed {
    buffer_view: u32,
    /// Attribute semantic to the Draco attribute's unique id (in name order, so that the
    /// first error reported does not depend on hashing).
    attributes: BTreeMap<String, u32>,
}

/// Decodes every Draco primitive. `view_bytes` gives a buffer view's bytes; the decoded
/// accessors together may not exceed `max_total` bytes. Returns each decoded accessor's
/// bytes, by accessor index.
pub(super) fn decode_accessors<'v>(
    root: &json::Root,
    view_bytes: impl Fn(json::Index<json::buffer::View>) -> Fallible<&'v [u8]>,
    max_total: u64,
) -> Fallible<HashMap<usize, Vec<u8>>> {
    let mut decoded: HashMap<usize, Vec<u8>> = HashMap::new();
    let mut total = 0u64;
    let mut keep = |accessor: usize, bytes: Vec<u8>, what: &str| -> Fallible<()> {
        total = total.saturating_add(bytes.len() as u64);
        if total > max_total {
            return Err(input(format!(
                "{what}: decoded data exceeds the {max_total} bytes capture reads"
            )));
        }
        match decoded.get(&accessor) {
            Some(earlier) if *earlier != bytes => Err(input(format!(
                "{what}: accessor {accessor} is decoded from two Draco streams with different data"
            ))),
            _ => {
                decoded.insert(accessor, bytes);
                Ok(())
            }
        }
    };
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let Some(ext) = primitive.extensions.as_ref().and_then(|e| e.others.get(EXTENSION)) else {
                continue;
            };
            let what = format!("primitive {p} of mesh {m} (Draco)");
            let c: Compressed =
                json::deserialize::from_value(ext.clone()).map_err(|e| input(format!("{what}: {e}")))?;
            let stream = view_bytes(json::Index::new(c.buffer_view))?;
            // draco-oxide is an alpha: on about 0.5% of random byte edits of a valid stream
            // it panics (a clamp with min > max, an index past its traversal table) instead
            // of returning an error, so its panics are contained and reported the same way.
            let mesh = crate::contained::contain(|| draco_oxide_decoder::Decoder::new().decode_mesh(stream))
                .map_err(|panic| input(format!("{what}: corrupt Draco data (the decoder failed: {panic})")))?
                .map_err(|e| input(format!("{what}: corrupt Draco data ({e})")))?;
            let points = mesh.attributes.first().map_or(0, Attribute::len);
            if let Some(a) = primitive.indices {
                let indices: Vec<f64> = mesh.faces.iter().flatten().map(|&p| usize::from(p) as f64).collect();
                let bytes = pack(root, a.value(), &indices, 1, &format!("{what} indices"))?;
                keep(a.value(), bytes, &what)?;
            }
            for (semantic, &id) in &c.attributes {
                let Some(accessor) = primitive
                    .attributes
                    .iter()
                    .find(|(s, _)| matches!(s, Checked::Valid(s) if s.to_string() == *semantic))
                    .map(|(_, a)| a.value())
                else {
                    continue;
                };
                let name = format!("{what} {semantic}");
                let attribute = mesh
                    .attributes
                    .iter()
                    .find(|a| a.get_id().as_usize() == id as usize)
                    .ok_or_else(|| input(format!("{name}: the stream has no attribute with id {id}")))?;
                if attribute.len() != points {
                    return Err(input(format!("{name}: {} values for {points} points", attribute.len())));
                }
                let values = values(attribute).ok_or_else(|| input(format!("{name}: unsupported Draco data type")))?;
                let bytes = pack(root, accessor, &values, attribute.get_num_components(), &name)?;
                keep(accessor, bytes, &what)?;
            }
        }
    }
    Ok(decoded)
}

/// Every point's components, in point order.
fn values(attribute: &Attribute) -> Option<Vec<f64>> {
    let component = attribute.get_component_type();
    let size = component.size();
    let read: fn(&[u8]) -> f64 = match component {
        ComponentDataType::F32 => |b| f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        ComponentDataType::U8 => |b| f64::from(b[0]),
        ComponentDataType::I8 => |b| f64::from(b[0] as i8),
        ComponentDataType::U16 => |b| f64::from(u16::from_le_bytes([b[0], b[1]])),
        ComponentDataType::I16 => |b| f64::from(i16::from_le_bytes([b[0], b[1]])),
        ComponentDataType::U32 => |b| f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        ComponentDataType::I32 => |b| f64::from(i32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        _ => return None,
    };
    let width = attribute.get_num_components();
    let data = attribute.get_data_as_bytes();
    let mut out = Vec::with_capacity(attribute.len() * width);
    for p in 0..attribute.len() {
        let value = usize::from(attribute.get_unique_val_idx(PointIdx::from(p)));
        let bytes = data.get(value * width * size..(value + 1) * width * size)?;
        out.extend(bytes.chunks_exact(size).map(read));
    }
    Some(out)
}

/// `values` (`width` per element) written in the accessor's component type, after checking
/// that the accessor's elements have that width. The element count is the stream's, as
/// three.js and gltf-transform read it: the accessor's `count` is what the encoder was
/// given, and the decoded points can be more (305 for 289 on the test grid).
fn pack(root: &json::Root, accessor: usize, values: &[f64], width: usize, what: &str) -> Fallible<Vec<u8>> {
    let a = root
        .accessors
        .get(accessor)
        .ok_or_else(|| input(format!("{what}: accessor {accessor} does not exist")))?;
    let what = format!("{what} (accessor {accessor})");
    let ty = valid(&a.type_, &what, "type")?;
    if ty.multiplicity() != width {
        return Err(input(format!(
            "{what} has {} components but the Draco attribute has {width}",
            ty.multiplicity()
        )));
    }
    let component = valid(&a.component_type, &what, "componentType")?.0;
    let mut out = Vec::with_capacity(values.len() * component.size());
    for &v in values {
        match component {
            ComponentType::F32 => out.extend((v as f32).to_le_bytes()),
            ComponentType::U8 => out.push(v as u8),
            ComponentType::I8 => out.extend((v as i8).to_le_bytes()),
            ComponentType::U16 => out.extend((v as u16).to_le_bytes()),
            ComponentType::I16 => out.extend((v as i16).to_le_bytes()),
            ComponentType::U32 => out.extend((v as u32).to_le_bytes()),
        }
    }
    Ok(out)
}
