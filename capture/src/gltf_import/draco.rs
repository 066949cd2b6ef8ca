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

use super::budget::GeometryBudget;
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

/// Decodes every Draco primitive. `view_bytes` gives a buffer view's bytes; each stream's
/// declared size is charged to `budget` before it is decoded. Returns each decoded
/// accessor's bytes, by accessor index.
pub(super) fn decode_accessors<'v>(
    root: &json::Root,
    view_bytes: impl Fn(json::Index<json::buffer::View>) -> Fallible<&'v [u8]>,
    budget: &GeometryBudget,
) -> Fallible<HashMap<usize, Vec<u8>>> {
    let mut decoded: HashMap<usize, Vec<u8>> = HashMap::new();
    let mut keep = |accessor: usize, bytes: Vec<u8>, what: &str| -> Fallible<()> {
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
            let indices = primitive
                .indices
                .ok_or_else(|| input(format!("{what} has no indices accessor, which the extension requires")))?;
            let index_count = root.accessors.get(indices.value()).map_or(0, |a| a.count.0);
            let (faces, points) = check_declared_counts(stream, index_count, &what)?;
            // The decoder's tables, before it runs: 8 bytes per corner and per point of each
            // attribute the file lists. What is unpacked from them is charged below.
            let decoded = (faces.saturating_mul(3)).saturating_add(points.saturating_mul(c.attributes.len() as u64));
            budget.charge(decoded, 8, &what)?;
            // draco-oxide is an alpha: on about 0.5% of random byte edits of a valid stream
            // it panics (a clamp with min > max, an index past its traversal table) instead
            // of returning an error, so its panics are contained and reported the same way.
            let mesh = crate::contained::contain(|| draco_oxide_decoder::Decoder::new().decode_mesh(stream))
                .map_err(|panic| input(format!("{what}: corrupt Draco data (the decoder failed: {panic})")))?
                .map_err(|e| input(format!("{what}: corrupt Draco data ({e})")))?;
            let points = mesh.attributes.first().map_or(0, Attribute::len);
            budget.charge(mesh.faces.len() as u64 * 3, 8, &format!("{what} indices"))?;
            let corners: Vec<f64> = mesh.faces.iter().flatten().map(|&p| usize::from(p) as f64).collect();
            let bytes = pack(root, indices.value(), &corners, 1, &format!("{what} indices"))?;
            keep(indices.value(), bytes, &what)?;
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
                // Each component is unpacked to an f64 (a stream's attribute may have more
                // components than its accessor, which `pack` refuses after).
                budget.charge((points * attribute.get_num_components()) as u64, 8, &name)?;
                let values = values(attribute).ok_or_else(|| input(format!("{name}: unsupported Draco data type")))?;
                let bytes = pack(root, accessor, &values, attribute.get_num_components(), &name)?;
                keep(accessor, bytes, &what)?;
            }
        }
    }
    Ok(decoded)
}

/// draco-oxide allocates its connectivity tables at the sizes a stream declares, before it
/// can find that the stream is short: the counts are checked here first against the
/// primitive's indices accessor (`index_count`), so that a few bytes cannot ask for
/// gigabytes. Streams with Draco metadata, whose layout only the decoder reads, are
/// refused (glTF exporters do not write it). Returns the declared faces and vertices.
fn check_declared_counts(stream: &[u8], index_count: u64, what: &str) -> Fallible<(u64, u64)> {
    use draco_oxide_core::bit_coder::Reader;
    use draco_oxide_core::codec::header::EncoderMethod;
    use draco_oxide_core::utils::bit_coder::leb128_read;
    let corrupt = |e: &dyn std::fmt::Display| input(format!("{what}: corrupt Draco data ({e})"));
    let mut reader = Reader::new(stream);
    let header = draco_oxide_decoder::header::decode_header(&mut reader).map_err(|e| corrupt(&e))?;
    if header.metadata {
        return Err(super::unsupported(format!("Draco metadata in {what}")));
    }
    let count = |reader: &mut Reader| leb128_read(reader).map_err(|e| corrupt(&e));
    let byte = |reader: &mut Reader| reader.read_u8().map_err(|e| corrupt(&e));
    let faces_allowed = index_count / 3;
    let (faces, vertices) = match header.encoder_method {
        EncoderMethod::Sequential => {
            let faces = count(&mut reader)?;
            (faces, count(&mut reader)?)
        }
        EncoderMethod::Edgebreaker => {
            let _traversal = byte(&mut reader)?;
            let vertices = count(&mut reader)?;
            let faces = count(&mut reader)?;
            let _attribute_data = byte(&mut reader)?;
            let (symbols, splits) = (count(&mut reader)?, count(&mut reader)?);
            if symbols > faces || splits > faces {
                return Err(input(format!(
                    "{what}: the Draco stream declares more symbols than faces"
                )));
            }
            (faces, vertices.saturating_add(splits))
        }
    };
    if faces > faces_allowed || vertices > faces.saturating_mul(3) {
        return Err(input(format!(
            "{what}: the Draco stream declares {faces} faces and {vertices} vertices, but its indices accessor \
             holds {index_count} indices"
        )));
    }
    Ok((faces, vertices))
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
    // Integer components take integer values in their range; anything else (an index past
    // a u16 accessor, a float into an integer attribute) is an error, not a saturated cast.
    let range = match component {
        ComponentType::F32 => None,
        ComponentType::U8 => Some((0.0, f64::from(u8::MAX))),
        ComponentType::I8 => Some((f64::from(i8::MIN), f64::from(i8::MAX))),
        ComponentType::U16 => Some((0.0, f64::from(u16::MAX))),
        ComponentType::I16 => Some((f64::from(i16::MIN), f64::from(i16::MAX))),
        ComponentType::U32 => Some((0.0, f64::from(u32::MAX))),
    };
    if let Some((lo, hi)) = range {
        if let Some(bad) = values.iter().find(|&&v| v.fract() != 0.0 || !(lo..=hi).contains(&v)) {
            return Err(input(format!(
                "{what}: decoded value {bad} does not fit its {component:?} components"
            )));
        }
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// An edgebreaker stream's header and counts: vertices, faces, symbols, split symbols.
    fn edgebreaker(vertices: u64, faces: u64, symbols: u64, splits: u64) -> Vec<u8> {
        let mut s = b"DRACO".to_vec();
        s.extend([2, 2, 1, 1, 0, 0, 0]); // version 2.2, mesh, edgebreaker, no flags; standard traversal
        let leb = |s: &mut Vec<u8>, mut v: u64| loop {
            let byte = (v & 0x7f) as u8;
            v >>= 7;
            if v == 0 {
                s.push(byte);
                break;
            }
            s.push(byte | 0x80);
        };
        leb(&mut s, vertices);
        leb(&mut s, faces);
        s.push(0); // attribute data
        leb(&mut s, symbols);
        leb(&mut s, splits);
        s
    }

    #[test]
    fn declared_counts_are_bounded_by_the_accessors_before_decoding() {
        assert!(check_declared_counts(&edgebreaker(12, 10, 10, 0), 30, "p").is_ok());
        for (stream, why) in [
            (edgebreaker(12, 1 << 40, 10, 0), "faces past the accessor"),
            (edgebreaker(1 << 40, 10, 10, 0), "vertices past three per face"),
            (edgebreaker(12, 10, 11, 0), "more symbols than faces"),
            (edgebreaker(12, 10, 10, 11), "more split symbols than faces"),
        ] {
            assert!(check_declared_counts(&stream, 30, "p").is_err(), "{why}");
        }
        let mut with_metadata = edgebreaker(12, 10, 10, 0);
        with_metadata[10] = 0x80; // the high byte of the flags: metadata
        assert!(matches!(
            check_declared_counts(&with_metadata, 30, "p"),
            Err(super::super::Problem::Unsupported(_))
        ));
        assert!(check_declared_counts(b"DRAC", 30, "p").is_err(), "truncated header");
    }
}
