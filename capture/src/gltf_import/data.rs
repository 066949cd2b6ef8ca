//! The bytes behind a glTF document: the GLB container, buffers (the GLB `BIN` chunk,
//! `data:` URIs, external files) and typed accessor reads.
//!
//! Everything is bounds-checked here rather than in the `gltf` crate's reader, whose
//! accessor iterators assert on inconsistent strides and index without checks, so that a
//! malformed file gets an error naming the broken object instead of a panic.

use std::collections::HashMap;
use std::path::Path;

use glam::{Mat4, Vec2, Vec3};
use gltf::json::{
    self,
    accessor::{ComponentType, Type},
};

use super::budget::GeometryBudget;
use super::{draco, input, meshopt, unsupported, valid, Fallible};

/// The JSON part of a file and, for a GLB container, its `BIN` chunk.
pub(super) struct Container<'a> {
    pub json: &'a [u8],
    pub bin: Option<&'a [u8]>,
}

const GLB_MAGIC: &[u8; 4] = b"glTF";
const GLB_HEADER_LEN: usize = 12;
const CHUNK_HEADER_LEN: usize = 8;
const CHUNK_JSON: u32 = u32::from_le_bytes(*b"JSON");
const CHUNK_BIN: u32 = u32::from_le_bytes(*b"BIN\0");

/// Splits a GLB container into its chunks; any other file is taken to be JSON.
pub(super) fn split_container(bytes: &[u8]) -> Fallible<Container<'_>> {
    if !bytes.starts_with(GLB_MAGIC) {
        return Ok(Container {
            json: lenient_json(bytes),
            bin: None,
        });
    }
    let word = |at: usize| {
        bytes
            .get(at..)
            .and_then(<[u8]>::first_chunk::<4>)
            .map(|b| u32::from_le_bytes(*b))
    };
    let (Some(version), Some(length)) = (word(4), word(8)) else {
        return Err(input("truncated GLB header"));
    };
    if version != 2 {
        return Err(unsupported(format!("GLB container version {version}")));
    }
    let length = length as usize;
    if length < GLB_HEADER_LEN || length > bytes.len() {
        return Err(input(format!(
            "GLB header gives a length of {length} bytes but the file has {}",
            bytes.len()
        )));
    }
    let (mut json, mut bin) = (None, None);
    let mut at = GLB_HEADER_LEN;
    while at < length {
        let (Some(chunk_len), Some(kind)) = (word(at), word(at + 4)) else {
            return Err(input(format!("truncated GLB chunk header at byte {at}")));
        };
        let start = at + CHUNK_HEADER_LEN;
        let end = start
            .checked_add(chunk_len as usize)
            .filter(|&end| end <= length)
            .ok_or_else(|| input(format!("GLB chunk at byte {at} runs past the end of the file")))?;
        let data = &bytes[start..end];
        // The spec puts JSON first and at most one BIN chunk after it; other chunk
        // types are to be ignored.
        match kind {
            CHUNK_JSON if json.is_none() => json = Some(data),
            CHUNK_BIN if json.is_some() && bin.is_none() => bin = Some(data),
            _ => {}
        }
        at = end;
    }
    let json = json.ok_or_else(|| input("GLB container has no JSON chunk"))?;
    Ok(Container {
        json: lenient_json(json),
        bin,
    })
}

/// JSON text without a UTF-8 byte-order mark or trailing NUL padding, which some
/// exporters write although the spec allows neither.
fn lenient_json(json: &[u8]) -> &[u8] {
    let json = json.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(json);
    let end = json.iter().rposition(|&b| b != 0).map_or(0, |last| last + 1);
    &json[..end]
}

/// Largest buffer a file may declare (`byteLength`) and the importer will read.
pub(super) const MAX_BUFFER_BYTES: u64 = 2 << 30;
/// Largest external image file the importer will read.
pub(super) const MAX_IMAGE_FILE_BYTES: u64 = 256 << 20;

/// The bytes a URI points to, plus the media type a `data:` URI declares.
///
/// Relative references are resolved against `folder` (the canonical directory of the glTF
/// file) and must name a regular file inside it, symbolic links resolved: absolute paths,
/// `..` out of the folder, devices and FIFOs are refused, so a shared model cannot make
/// capture read (and put into a trace) anything but its own files. At most `max_len + 1`
/// bytes are read, so that the caller can tell a longer file. URIs with a scheme other than `data:` (http, file, ...) are not
/// followed.
pub(super) fn read_uri(uri: &str, folder: &Path, what: &str, max_len: u64) -> Fallible<(Vec<u8>, Option<String>)> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (header, payload) = rest
            .split_once(',')
            .ok_or_else(|| input(format!("{what}: malformed data URI")))?;
        let Some(media_type) = header.strip_suffix(";base64") else {
            return Err(unsupported(format!("data URI without base64 encoding in {what}")));
        };
        let bytes = decode_base64(payload).ok_or_else(|| input(format!("{what}: invalid base64 in data URI")))?;
        let media_type = (!media_type.is_empty()).then(|| media_type.to_string());
        return Ok((bytes, media_type));
    }
    if let Some(scheme) = uri_scheme(uri) {
        return Err(unsupported(format!("URI scheme `{scheme}:` in {what}")));
    }
    let relative = percent_decode(uri).ok_or_else(|| input(format!("{what}: malformed URI {uri:?}")))?;
    let outside = || {
        input(format!(
            "{what}: {relative:?} is outside the model's folder {} (only files inside it are read)",
            folder.display()
        ))
    };
    // Lexically first, so that nothing outside is even looked up; then with symbolic links
    // resolved.
    if escapes(Path::new(&relative)) {
        return Err(outside());
    }
    let cannot = |e: std::io::Error| input(format!("{what}: cannot read {relative}: {e}"));
    let path = folder.join(&relative).canonicalize().map_err(cannot)?;
    if !path.starts_with(folder) {
        return Err(outside());
    }
    let bytes = read_regular_file(&path, max_len).map_err(|e| input(format!("{what}: {relative}: {e}")))?;
    Ok((bytes, None))
}

/// Whether a relative path names something outside its base: it is absolute (or has a
/// drive prefix), or a `..` climbs above where it started.
fn escapes(path: &Path) -> bool {
    use std::path::Component;
    let mut depth = 0usize;
    for component in path.components() {
        match component {
            Component::Prefix(_) | Component::RootDir => return true,
            Component::ParentDir if depth == 0 => return true,
            Component::ParentDir => depth -= 1,
            Component::Normal(_) => depth += 1,
            Component::CurDir => {}
        }
    }
    false
}

/// At most `max_len + 1` bytes of `path`, which must be a regular file.
pub(super) fn read_regular_file(path: &Path, max_len: u64) -> Result<Vec<u8>, String> {
    use std::io::Read;
    let regular = |m: &std::fs::Metadata| {
        if m.is_file() {
            Ok(())
        } else {
            Err("not a regular file (devices, FIFOs and directories are refused)".to_string())
        }
    };
    // Checked before opening: opening a FIFO would block until someone writes to it.
    regular(&std::fs::metadata(path).map_err(|e| e.to_string())?)?;
    let file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    regular(&file.metadata().map_err(|e| e.to_string())?)?;
    let mut bytes = Vec::new();
    file.take(max_len.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|e| e.to_string())?;
    Ok(bytes)
}

/// The last path segment of a relative URI (a texture's fallback name); `None` for
/// `data:` and other absolute URIs.
pub(super) fn uri_file_name(uri: &str) -> Option<String> {
    if uri.starts_with("data:") || uri_scheme(uri).is_some() {
        return None;
    }
    let name = percent_decode(uri)?;
    let name = name.rsplit(['/', '\\']).next()?;
    (!name.is_empty()).then(|| name.to_string())
}

/// The scheme of an absolute URI (RFC 3986: a letter, then letters, digits, `+ - .`,
/// then `:`), or `None` for a relative reference.
fn uri_scheme(uri: &str) -> Option<&str> {
    let (scheme, _) = uri.split_once(':')?;
    let mut chars = scheme.chars();
    let first_ok = chars.next().is_some_and(|c| c.is_ascii_alphabetic());
    let rest_ok = chars.all(|c| c.is_ascii_alphanumeric() || matches!(c, '+' | '-' | '.'));
    (first_ok && rest_ok).then_some(scheme)
}

/// Decodes `%XX` escapes; `None` if an escape is malformed or the result is not UTF-8.
fn percent_decode(text: &str) -> Option<String> {
    let bytes = text.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = std::str::from_utf8(bytes.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

/// Standard base64 (RFC 4648 alphabet), `=` padding optional as exporters differ;
/// `None` on other characters.
fn decode_base64(text: &str) -> Option<Vec<u8>> {
    use base64::engine::{general_purpose::GeneralPurpose, DecodePaddingMode, GeneralPurposeConfig};
    use base64::Engine;
    const LENIENT: GeneralPurpose = GeneralPurpose::new(
        &base64::alphabet::STANDARD,
        GeneralPurposeConfig::new()
            .with_decode_padding_mode(DecodePaddingMode::Indifferent)
            .with_decode_allow_trailing_bits(true),
    );
    LENIENT.decode(text).ok()
}

/// Converts one component's little-endian bytes.
type Decode<T> = fn(&[u8]) -> T;

/// The first `N` bytes of a component slice. Slices handed to decoders always have the
/// component's size, so the zero fallback is never taken.
fn le<const N: usize>(bytes: &[u8]) -> [u8; N] {
    bytes.first_chunk::<N>().copied().unwrap_or([0; N])
}

/// Float decoding per the glTF spec: integer components are converted as values, or
/// mapped to [0, 1] / [-1, 1] when the accessor is `normalized`.
fn float_decoder(component: ComponentType, normalized: bool) -> Option<Decode<f32>> {
    use ComponentType::*;
    Some(match (component, normalized) {
        (F32, _) => |b| f32::from_le_bytes(le(b)),
        (U8, false) => |b| f32::from(u8::from_le_bytes(le(b))),
        (U8, true) => |b| f32::from(u8::from_le_bytes(le(b))) / 255.0,
        (I8, false) => |b| f32::from(i8::from_le_bytes(le(b))),
        (I8, true) => |b| (f32::from(i8::from_le_bytes(le(b))) / 127.0).max(-1.0),
        (U16, false) => |b| f32::from(u16::from_le_bytes(le(b))),
        (U16, true) => |b| f32::from(u16::from_le_bytes(le(b))) / 65535.0,
        (I16, false) => |b| f32::from(i16::from_le_bytes(le(b))),
        (I16, true) => |b| (f32::from(i16::from_le_bytes(le(b))) / 32767.0).max(-1.0),
        (U32, false) => |b| u32::from_le_bytes(le(b)) as f32,
        (U32, true) => |b| (f64::from(u32::from_le_bytes(le(b))) / f64::from(u32::MAX)) as f32,
    })
}

/// Unsigned integer decoding (indices, joints); other component types are rejected.
fn uint_decoder(component: ComponentType) -> Option<Decode<u32>> {
    match component {
        ComponentType::U8 => Some(|b| u32::from(u8::from_le_bytes(le(b)))),
        ComponentType::U16 => Some(|b| u32::from(u16::from_le_bytes(le(b)))),
        ComponentType::U32 => Some(|b| u32::from_le_bytes(le(b))),
        _ => None,
    }
}

fn type_name(ty: Type) -> &'static str {
    match ty {
        Type::Scalar => "SCALAR",
        Type::Vec2 => "VEC2",
        Type::Vec3 => "VEC3",
        Type::Vec4 => "VEC4",
        Type::Mat2 => "MAT2",
        Type::Mat3 => "MAT3",
        Type::Mat4 => "MAT4",
    }
}

fn to_usize(value: u64, what: &str) -> Fallible<usize> {
    usize::try_from(value).map_err(|_| input(format!("{what}: {value} is too large")))
}

/// The document's buffers, loaded, and checked reads of its buffer views and accessors.
pub(super) struct Reader<'a> {
    root: &'a json::Root,
    buffers: Vec<Vec<u8>>,
    /// The decoded bytes of meshopt-compressed buffer views, by view index.
    decoded_views: HashMap<usize, Vec<u8>>,
    /// The elements of accessors decoded from Draco streams, tightly packed, by accessor
    /// index; they replace the accessor's (absent) buffer view.
    decoded_accessors: HashMap<usize, Vec<u8>>,
    /// Charged for every decode and every accessor read.
    budget: GeometryBudget,
}

impl<'a> Reader<'a> {
    /// Loads every buffer: the GLB `BIN` chunk for the buffer without a URI, otherwise
    /// the URI's bytes, read up to the declared `byteLength` (at most
    /// [`MAX_BUFFER_BYTES`]). Each must hold at least its declared `byteLength`, except a
    /// meshopt fallback buffer, which is never read: its views are decoded from
    /// compressed bytes elsewhere. Draco primitives are decoded here too. Those decodes,
    /// and every accessor read after them, are charged to `geometry_bytes`
    /// ([`super::ImportLimits::geometry_bytes`]).
    pub fn new(
        root: &'a json::Root,
        mut bin: Option<&[u8]>,
        folder: &Path,
        geometry_bytes: u64,
    ) -> Fallible<Reader<'a>> {
        let mut buffers = Vec::with_capacity(root.buffers.len());
        for (i, buffer) in root.buffers.iter().enumerate() {
            let what = format!("buffer {i}");
            let declared = buffer.byte_length.0;
            if declared > MAX_BUFFER_BYTES {
                return Err(input(format!(
                    "{what} declares byteLength {declared}, more than the {MAX_BUFFER_BYTES} bytes capture reads"
                )));
            }
            if meshopt::is_fallback(buffer) {
                buffers.push(Vec::new());
                continue;
            }
            let bytes = match &buffer.uri {
                Some(uri) => {
                    let mut bytes = read_uri(uri, folder, &what, declared)?.0;
                    // A file's bytes past the declared length are not the buffer's.
                    bytes.truncate(declared as usize);
                    bytes
                }
                None => bin
                    .take()
                    .ok_or_else(|| input(format!("{what} has no uri and there is no GLB BIN chunk for it")))?
                    .to_vec(),
            };
            if (bytes.len() as u64) < declared {
                return Err(input(format!(
                    "{what} holds {} bytes but declares byteLength {declared}",
                    bytes.len()
                )));
            }
            buffers.push(bytes);
        }
        let budget = GeometryBudget::new(geometry_bytes);
        let decoded_views = meshopt::decode_views(root, &buffers, &budget)?;
        let mut reader = Reader {
            root,
            buffers,
            decoded_views,
            decoded_accessors: HashMap::new(),
            budget,
        };
        reader.decoded_accessors = draco::decode_accessors(root, |v| reader.view_bytes(v), &reader.budget)?;
        Ok(reader)
    }

    /// The bytes of one buffer view.
    pub fn view_bytes(&self, index: json::Index<json::buffer::View>) -> Fallible<&[u8]> {
        let v = index.value();
        if let Some(bytes) = self.decoded_views.get(&v) {
            return Ok(bytes);
        }
        let view = self
            .root
            .buffer_views
            .get(v)
            .ok_or_else(|| input(format!("buffer view {v} does not exist")))?;
        let b = view.buffer.value();
        let data = self
            .buffers
            .get(b)
            .ok_or_else(|| input(format!("buffer view {v} uses buffer {b}, which does not exist")))?;
        let what = format!("buffer view {v}");
        let start = to_usize(view.byte_offset.map_or(0, |o| o.0), &what)?;
        let len = to_usize(view.byte_length.0, &what)?;
        start
            .checked_add(len)
            .and_then(|end| data.get(start..end))
            .ok_or_else(|| input(format!("{what} extends past the end of buffer {b}")))
    }

    pub fn scalars(&self, index: json::Index<json::Accessor>, what: &str) -> Fallible<Vec<f32>> {
        self.floats(index, Type::Scalar, what)
    }

    pub fn vec2s(&self, index: json::Index<json::Accessor>, what: &str) -> Fallible<Vec<Vec2>> {
        let flat = self.floats(index, Type::Vec2, what)?;
        Ok(flat.chunks_exact(2).map(Vec2::from_slice).collect())
    }

    pub fn vec3s(&self, index: json::Index<json::Accessor>, what: &str) -> Fallible<Vec<Vec3>> {
        let flat = self.floats(index, Type::Vec3, what)?;
        Ok(flat.chunks_exact(3).map(Vec3::from_slice).collect())
    }

    pub fn vec4s(&self, index: json::Index<json::Accessor>, what: &str) -> Fallible<Vec<[f32; 4]>> {
        let flat = self.floats(index, Type::Vec4, what)?;
        Ok(flat.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]).collect())
    }

    pub fn mat4s(&self, index: json::Index<json::Accessor>, what: &str) -> Fallible<Vec<Mat4>> {
        let flat = self.floats(index, Type::Mat4, what)?;
        Ok(flat.chunks_exact(16).map(Mat4::from_cols_slice).collect())
    }

    /// Unsigned integer scalars (vertex indices).
    pub fn uints(&self, index: json::Index<json::Accessor>, what: &str) -> Fallible<Vec<u32>> {
        self.components(index, Type::Scalar, what, |c, _| uint_decoder(c))
    }

    /// Unsigned integer 4-vectors (joint indices).
    pub fn uvec4s(&self, index: json::Index<json::Accessor>, what: &str) -> Fallible<Vec<[u32; 4]>> {
        let flat = self.components(index, Type::Vec4, what, |c, _| uint_decoder(c))?;
        Ok(flat.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]).collect())
    }

    /// `count * components` floats, flat; the accessor must have type `ty`.
    pub fn floats(&self, index: json::Index<json::Accessor>, ty: Type, what: &str) -> Fallible<Vec<f32>> {
        self.components(index, ty, what, float_decoder)
    }

    /// Reads every component of an accessor, base data and sparse substitutions, after
    /// checking its type and that all bytes it addresses exist. Matrices are read
    /// without column padding, which is only correct for `MAT4` and 4-byte `MAT2/MAT3`:
    /// the only matrices read are `MAT4` inverse bind matrices.
    fn components<T: Copy + Default>(
        &self,
        index: json::Index<json::Accessor>,
        ty: Type,
        what: &str,
        decoder: impl Fn(ComponentType, bool) -> Option<Decode<T>>,
    ) -> Fallible<Vec<T>> {
        let i = index.value();
        let accessor = self
            .root
            .accessors
            .get(i)
            .ok_or_else(|| input(format!("{what}: accessor {i} does not exist")))?;
        let what = format!("{what} (accessor {i})");
        let found = valid(&accessor.type_, &what, "type")?;
        if found != ty {
            return Err(input(format!(
                "{what} is {}, expected {}",
                type_name(found),
                type_name(ty)
            )));
        }
        let component = valid(&accessor.component_type, &what, "componentType")?.0;
        let decode = decoder(component, accessor.normalized).ok_or_else(|| {
            input(format!(
                "{what} has component type {component:?}, which is not allowed here"
            ))
        })?;
        let width = ty.multiplicity();
        let size = component.size();
        let element = width * size;
        let count = to_usize(accessor.count.0, &what)?;
        if let Some(bytes) = self.decoded_accessors.get(&i) {
            // Draco accessors have no sparse part: their elements are all there is (as many
            // as the stream decoded, whatever `count` says).
            self.budget
                .charge((bytes.len() / size) as u64, std::mem::size_of::<T>() as u64, &what)?;
            return Ok(bytes.chunks_exact(size).map(decode).collect());
        }
        // Charged before anything is allocated: an accessor without a buffer view is
        // all zeros, so its count is backed by no file bytes.
        self.budget
            .charge(accessor.count.0, (width * std::mem::size_of::<T>()) as u64, &what)?;

        let mut out: Vec<T> = match accessor.buffer_view {
            Some(v) => {
                let bytes = self.view_bytes(v)?;
                let view = &self.root.buffer_views[v.value()];
                let stride = view.byte_stride.map_or(element, |s| s.0);
                if stride < element {
                    return Err(input(format!(
                        "{what}: byteStride {stride} is smaller than one element ({element} bytes)"
                    )));
                }
                let offset = to_usize(accessor.byte_offset.map_or(0, |o| o.0), &what)?;
                let end = match count {
                    0 => Some(offset),
                    n => (n - 1)
                        .checked_mul(stride)
                        .and_then(|x| x.checked_add(element))
                        .and_then(|x| x.checked_add(offset)),
                };
                if end.is_none_or(|end| end > bytes.len()) {
                    return Err(input(format!("{what} reads past the end of buffer view {v}")));
                }
                let mut out = Vec::with_capacity(count * width);
                for k in 0..count {
                    let start = offset + k * stride;
                    out.extend(bytes[start..start + element].chunks_exact(size).map(decode));
                }
                out
            }
            None => vec![T::default(); count * width],
        };

        if let Some(sparse) = &accessor.sparse {
            let what = format!("{what} sparse");
            let n = to_usize(sparse.count.0, &what)?;
            let index_component = valid(&sparse.indices.component_type, &what, "indices componentType")?.0;
            let index_decode = uint_decoder(index_component)
                .ok_or_else(|| input(format!("{what} indices are not unsigned integers")))?;
            let packed = |view, offset: u64, item: usize| -> Fallible<&[u8]> {
                let bytes = self.view_bytes(view)?;
                let start = to_usize(offset, &what)?;
                n.checked_mul(item)
                    .and_then(|len| bytes.get(start..)?.get(..len))
                    .ok_or_else(|| input(format!("{what} reads past the end of buffer view {view}")))
            };
            let indices = packed(
                sparse.indices.buffer_view,
                sparse.indices.byte_offset.0,
                index_component.size(),
            )?;
            let values = packed(sparse.values.buffer_view, sparse.values.byte_offset.0, element)?;
            for (ib, vb) in indices
                .chunks_exact(index_component.size())
                .zip(values.chunks_exact(element))
            {
                let target = index_decode(ib) as usize;
                if target >= count {
                    return Err(input(format!("{what} index {target} out of range ({count} elements)")));
                }
                let slots = &mut out[target * width..(target + 1) * width];
                for (slot, value) in slots.iter_mut().zip(vb.chunks_exact(size).map(decode)) {
                    *slot = value;
                }
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_round_trips_known_vectors() {
        assert_eq!(decode_base64("").unwrap(), b"");
        assert_eq!(decode_base64("Zg==").unwrap(), b"f");
        assert_eq!(decode_base64("Zm8=").unwrap(), b"fo");
        assert_eq!(decode_base64("Zm9v").unwrap(), b"foo");
        assert_eq!(decode_base64("Zm9vYmFy").unwrap(), b"foobar");
        assert_eq!(decode_base64("AP8/+w==").unwrap(), [0x00, 0xff, 0x3f, 0xfb]);
        assert!(decode_base64("Zm9v!").is_none());
    }

    #[test]
    fn uris_are_classified_and_decoded() {
        assert_eq!(uri_scheme("http://x/y.bin"), Some("http"));
        assert_eq!(uri_scheme("file:///tmp/a.bin"), Some("file"));
        assert_eq!(uri_scheme("textures/a.png"), None);
        assert_eq!(uri_scheme("./a:b.png"), None);
        assert_eq!(percent_decode("my%20file.bin").as_deref(), Some("my file.bin"));
        assert_eq!(percent_decode("bad%2"), None);
        assert_eq!(percent_decode("bad%zz"), None);
        assert_eq!(percent_decode("%ff"), None);
        assert_eq!(uri_file_name("tex/wood%20grain.png").as_deref(), Some("wood grain.png"));
        assert_eq!(uri_file_name("data:image/png;base64,AAAA"), None);
    }

    #[test]
    fn data_uri_is_decoded_without_touching_the_file_system() {
        let (bytes, media) = read_uri(
            "data:application/octet-stream;base64,AQID",
            Path::new("/nonexistent"),
            "b",
            16,
        )
        .unwrap();
        assert_eq!(bytes, [1, 2, 3]);
        assert_eq!(media.as_deref(), Some("application/octet-stream"));
        assert!(matches!(
            read_uri("https://example.com/a.bin", Path::new("."), "b", 16),
            Err(super::super::Problem::Unsupported(_))
        ));
    }

    #[test]
    fn malformed_glb_containers_are_errors() {
        let mut glb = b"glTF".to_vec();
        glb.extend_from_slice(&2u32.to_le_bytes());
        assert!(split_container(&glb).is_err(), "truncated header");
        glb.extend_from_slice(&4u32.to_le_bytes());
        assert!(split_container(&glb).is_err(), "length below the header size");
        let mut ok = b"glTF".to_vec();
        ok.extend_from_slice(&2u32.to_le_bytes());
        ok.extend_from_slice(&(12u32 + 8 + 4).to_le_bytes());
        ok.extend_from_slice(&4u32.to_le_bytes());
        ok.extend_from_slice(b"JSON");
        ok.extend_from_slice(b"{}  ");
        let container = split_container(&ok).unwrap();
        assert_eq!(container.json, b"{}  ");
        assert!(container.bin.is_none());
        // NUL padding is tolerated.
        ok[20..24].copy_from_slice(b"{}\0\0");
        assert_eq!(split_container(&ok).unwrap().json, b"{}");
        // A chunk claiming more bytes than the file holds.
        ok[12..16].copy_from_slice(&400u32.to_le_bytes());
        assert!(split_container(&ok).is_err());
    }

    #[test]
    fn json_byte_order_mark_and_nul_padding_are_tolerated() {
        assert_eq!(lenient_json(b"\xEF\xBB\xBF{}\0\0"), b"{}");
        assert_eq!(lenient_json(b"\0"), b"");
        assert_eq!(split_container(b"\xEF\xBB\xBF{ }").unwrap().json, b"{ }");
    }

    #[test]
    fn normalized_integers_follow_the_spec() {
        let u8n = float_decoder(ComponentType::U8, true).unwrap();
        assert_eq!(u8n(&[255]), 1.0);
        let i8n = float_decoder(ComponentType::I8, true).unwrap();
        assert_eq!(i8n(&[0x80]), -1.0);
        let u16n = float_decoder(ComponentType::U16, true).unwrap();
        assert_eq!(u16n(&0xffffu16.to_le_bytes()), 1.0);
        assert!(uint_decoder(ComponentType::F32).is_none());
    }
}
