//! The chunked container: `STRC`, format major/minor, a header extension, then chunks
//! `{kind u32, raw_len u64, packed_len u64, bytes}`, each zstd-compressed on its own and
//! ending with an uncompressed `End` chunk that carries the content hash.
//!
//! Layout (all integers little-endian):
//!
//! ```text
//! "STRC" major:u16 minor:u16 ext_len:u32 ext[ext_len]
//! Meta Geometry Materials Textures Lights Frame*   (chunks of unknown kind may appear
//! End(raw_len = packed_len = 32, SHA-256)           between them; readers skip them)
//! ```
//!
//! The reader indexes chunk headers only, so seeking to frame N decodes nothing else.
//! Every declared length is checked against the bytes the file really has before any
//! buffer is sized from it, and decompressed lengths are bounded by the file's size
//! ([`decompressed_limit`]), so a small hostile file cannot make a reader allocate much.

use std::io::{Read, Seek, SeekFrom, Write};

use serde::de::DeserializeOwned;
use serde::Serialize;

use crate::error::{Error, Result};
use crate::hash::{ContentHash, ContentHasher};
use crate::schema::{Frame, Geometry, Light, Material, Meta, Scene, SurfaceMaps, Texture};
use crate::validate;

pub const MAGIC: [u8; 4] = *b"STRC";
pub const FORMAT_MAJOR: u16 = 1;
/// The newest minor this reader reads. A writer writes the oldest minor that holds
/// everything in its file: 1 only with a `SurfaceMaps` chunk, so other traces stay
/// byte-identical to minor-0 ones.
pub const FORMAT_MINOR: u16 = 1;
/// Default zstd level of the writer (the level never changes the content hash).
pub const DEFAULT_ZSTD_LEVEL: i32 = 9;
/// Largest header extension a reader accepts.
pub const MAX_HEADER_EXTENSION: u32 = 64 * 1024;
/// Largest decompressed chunk a reader accepts.
pub const MAX_CHUNK_RAW_LEN: u64 = 4 << 30;
/// A chunk may decompress to at most this many times its compressed size, and a file's
/// chunks to this many times the file's size in all (real traces stay under 20x) ...
pub const MAX_EXPANSION: u64 = 256;
/// ... or to this many bytes, whichever is larger (highly compressible scenes, such as
/// uniform textures, stay readable when small).
pub const EXPANSION_ALLOWANCE: u64 = 64 << 20;
const CHUNK_HEADER_LEN: u64 = 20;
const FILE_HEADER_LEN: u64 = 12;
const HASH_LEN: u64 = 32;
/// bincode's allocation limit when decoding a payload.
const DECODE_LIMIT: usize = 4 << 30;
/// Decompression buffers start no larger than this, then grow with real output.
const INITIAL_DECOMPRESS_CAPACITY: u64 = 16 << 20;
/// Block size of streamed reads (hashing, decompression input).
const STREAM_BLOCK: usize = 64 << 10;

/// The most bytes `compressed` bytes may decompress to (per chunk, or per file in all).
pub fn decompressed_limit(compressed: u64) -> u64 {
    compressed
        .saturating_mul(MAX_EXPANSION)
        .clamp(EXPANSION_ALLOWANCE, MAX_CHUNK_RAW_LEN)
}

/// The kind of a chunk.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum ChunkKind {
    Meta,
    Geometry,
    Materials,
    Textures,
    Lights,
    /// Minor 1, optional: [`SurfaceMaps`](crate::SurfaceMaps), between `Lights` and the frames.
    SurfaceMaps,
    Frame,
    End,
    /// A kind from a newer minor version: skipped (but hashed) by this reader.
    Unknown(u32),
}

impl ChunkKind {
    pub fn code(self) -> u32 {
        match self {
            ChunkKind::Meta => 1,
            ChunkKind::Geometry => 2,
            ChunkKind::Materials => 3,
            ChunkKind::Textures => 4,
            ChunkKind::Lights => 5,
            ChunkKind::Frame => 6,
            ChunkKind::SurfaceMaps => 7,
            ChunkKind::End => 0x2144_4E45, // "END!"
            ChunkKind::Unknown(code) => code,
        }
    }

    pub fn from_code(code: u32) -> ChunkKind {
        [
            ChunkKind::Meta,
            ChunkKind::Geometry,
            ChunkKind::Materials,
            ChunkKind::Textures,
            ChunkKind::Lights,
            ChunkKind::SurfaceMaps,
            ChunkKind::Frame,
            ChunkKind::End,
        ]
        .into_iter()
        .find(|k| k.code() == code)
        .unwrap_or(ChunkKind::Unknown(code))
    }
}

impl std::fmt::Display for ChunkKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ChunkKind::Unknown(code) => write!(f, "Unknown({code:#x})"),
            other => write!(f, "{other:?}"),
        }
    }
}

/// Where a chunk's payload sits and how big it is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChunkInfo {
    pub kind: ChunkKind,
    /// File offset of the (compressed) payload bytes.
    pub offset: u64,
    pub raw_len: u64,
    pub packed_len: u64,
}

fn encode<T: Serialize>(kind: ChunkKind, value: &T) -> Result<Vec<u8>> {
    bincode::serde::encode_to_vec(value, bincode::config::standard()).map_err(|e| Error::Encode {
        kind,
        msg: e.to_string(),
    })
}

fn decode<T: DeserializeOwned>(kind: ChunkKind, bytes: &[u8]) -> Result<T> {
    let config = bincode::config::standard().with_limit::<DECODE_LIMIT>();
    let (value, used) = bincode::serde::decode_from_slice(bytes, config).map_err(|e| Error::Decode {
        kind,
        msg: e.to_string(),
    })?;
    if used != bytes.len() {
        return Err(Error::Decode {
            kind,
            msg: format!("{} trailing bytes after the payload", bytes.len() - used),
        });
    }
    Ok(value)
}

/// Streams a trace: the static chunks at creation, frames one by one, the hash last.
pub struct TraceWriter<W: Write> {
    out: W,
    level: i32,
    hasher: ContentHasher,
    meta: Meta,
    frames_written: u32,
    /// Bytes written so far and their decompressed payload bytes, to refuse a file
    /// readers would refuse.
    bytes_written: u64,
    raw_written: u64,
}

impl<W: Write> TraceWriter<W> {
    /// Writes the file header and the `Meta`, `Geometry`, `Materials`, `Textures` and
    /// `Lights` chunks. `level` is the zstd level (it does not change the hash).
    pub fn new(mut out: W, level: i32, meta: &Meta, scene: &Scene) -> Result<Self> {
        validate::check_meta(meta)?;
        validate::check_scene(scene, &meta.counts)?;
        out.write_all(&MAGIC)?;
        out.write_all(&FORMAT_MAJOR.to_le_bytes())?;
        let minor: u16 = if scene.surface_maps.is_empty() { 0 } else { 1 };
        out.write_all(&minor.to_le_bytes())?;
        out.write_all(&0u32.to_le_bytes())?;
        let mut writer = TraceWriter {
            out,
            level,
            hasher: ContentHasher::default(),
            meta: meta.clone(),
            frames_written: 0,
            bytes_written: FILE_HEADER_LEN,
            raw_written: 0,
        };
        writer.write_value(ChunkKind::Meta, meta)?;
        writer.write_value(ChunkKind::Geometry, &scene.geometry)?;
        writer.write_value(ChunkKind::Materials, &scene.materials)?;
        writer.write_value(ChunkKind::Textures, &scene.textures)?;
        writer.write_value(ChunkKind::Lights, &scene.lights)?;
        if !scene.surface_maps.is_empty() {
            writer.write_value(ChunkKind::SurfaceMaps, &scene.surface_maps)?;
        }
        Ok(writer)
    }

    /// Appends the next frame; frames must come in index order, as many as `Meta` says.
    pub fn write_frame(&mut self, frame: &Frame) -> Result<()> {
        if frame.index != self.frames_written || frame.index >= self.meta.counts.frames {
            return Err(Error::Invalid(format!(
                "frame {} written out of order (expected {} of {})",
                frame.index, self.frames_written, self.meta.counts.frames
            )));
        }
        validate::check_frame(frame, &self.meta.counts)?;
        self.write_value(ChunkKind::Frame, frame)?;
        self.frames_written += 1;
        Ok(())
    }

    /// Writes the `End` chunk and returns the sink and the content hash.
    pub fn finish(mut self) -> Result<(W, ContentHash)> {
        if self.frames_written != self.meta.counts.frames {
            return Err(Error::Invalid(format!(
                "{} frames written, meta promises {}",
                self.frames_written, self.meta.counts.frames
            )));
        }
        let hash = std::mem::take(&mut self.hasher).finish();
        self.write_header(ChunkKind::End, HASH_LEN, HASH_LEN)?;
        self.out.write_all(&hash.0)?;
        self.out.flush()?;
        Ok((self.out, hash))
    }

    fn write_value<T: Serialize>(&mut self, kind: ChunkKind, value: &T) -> Result<()> {
        let raw = encode(kind, value)?;
        self.write_chunk(kind, &raw)
    }

    fn write_chunk(&mut self, kind: ChunkKind, raw: &[u8]) -> Result<()> {
        let mut encoder = zstd::stream::Encoder::new(Vec::new(), self.level)?;
        encoder.include_checksum(true)?;
        encoder.set_pledged_src_size(Some(raw.len() as u64))?;
        encoder.write_all(raw)?;
        let packed = encoder.finish()?;
        let (raw_len, packed_len) = (raw.len() as u64, packed.len() as u64);
        self.bytes_written += CHUNK_HEADER_LEN + packed_len;
        self.raw_written += raw_len;
        if raw_len > decompressed_limit(packed_len) || self.raw_written > decompressed_limit(self.bytes_written) {
            return Err(Error::Invalid(format!(
                "{kind} chunk compresses {raw_len} bytes to {packed_len}, more than readers accept \
                 (at most {MAX_EXPANSION}x, or {EXPANSION_ALLOWANCE} bytes)"
            )));
        }
        self.hasher.add_chunk(kind.code(), raw);
        self.write_header(kind, raw_len, packed_len)?;
        self.out.write_all(&packed)?;
        Ok(())
    }

    fn write_header(&mut self, kind: ChunkKind, raw_len: u64, packed_len: u64) -> Result<()> {
        self.out.write_all(&kind.code().to_le_bytes())?;
        self.out.write_all(&raw_len.to_le_bytes())?;
        self.out.write_all(&packed_len.to_le_bytes())?;
        Ok(())
    }
}

/// Random-access reader over a trace. Opening reads chunk headers and the `Meta` chunk;
/// everything else is decoded on demand.
pub struct TraceReader<R: Read + Seek> {
    src: R,
    version: (u16, u16),
    file_len: u64,
    chunks: Vec<ChunkInfo>,
    frame_chunks: Vec<usize>,
    stored_hash: ContentHash,
    meta: Meta,
}

impl<R: Read + Seek> TraceReader<R> {
    pub fn open(mut src: R) -> Result<Self> {
        let file_len = src.seek(SeekFrom::End(0))?;
        src.seek(SeekFrom::Start(0))?;
        if file_len < FILE_HEADER_LEN {
            return Err(Error::Truncated(format!(
                "{file_len} bytes, shorter than the file header"
            )));
        }
        let mut header = [0u8; FILE_HEADER_LEN as usize];
        src.read_exact(&mut header)?;
        let magic: [u8; 4] = header[0..4].try_into().expect("4 bytes");
        if magic != MAGIC {
            return Err(Error::BadMagic(magic));
        }
        let major = u16::from_le_bytes([header[4], header[5]]);
        let minor = u16::from_le_bytes([header[6], header[7]]);
        if major > FORMAT_MAJOR {
            return Err(Error::NewerMajor {
                found_major: major,
                found_minor: minor,
                supported_major: FORMAT_MAJOR,
            });
        }
        if major < FORMAT_MAJOR {
            return Err(Error::OlderMajor(major, FORMAT_MAJOR));
        }
        let ext_len = u32::from_le_bytes(header[8..12].try_into().expect("4 bytes"));
        if ext_len > MAX_HEADER_EXTENSION {
            return Err(Error::Corrupt(format!(
                "header extension of {ext_len} bytes exceeds {MAX_HEADER_EXTENSION}"
            )));
        }
        let first_chunk = FILE_HEADER_LEN + ext_len as u64;
        if first_chunk > file_len {
            return Err(Error::Truncated("file ends inside the header extension".into()));
        }
        let (chunks, stored_hash) = index_chunks(&mut src, first_chunk, file_len)?;
        let frame_chunks = check_order(&chunks)?;
        let meta: Meta = decode(ChunkKind::Meta, &read_raw(&mut src, chunks[0])?)?;
        validate::check_meta(&meta)?;
        if meta.counts.frames as usize != frame_chunks.len() {
            return Err(Error::Corrupt(format!(
                "meta promises {} frames, file holds {}",
                meta.counts.frames,
                frame_chunks.len()
            )));
        }
        Ok(TraceReader {
            src,
            version: (major, minor),
            file_len,
            chunks,
            frame_chunks,
            stored_hash,
            meta,
        })
    }

    pub fn meta(&self) -> &Meta {
        &self.meta
    }

    /// Format (major, minor) of the file.
    pub fn version(&self) -> (u16, u16) {
        self.version
    }

    pub fn file_len(&self) -> u64 {
        self.file_len
    }

    /// The content hash recorded in the `End` chunk (see [`TraceReader::verify`]).
    pub fn content_hash(&self) -> ContentHash {
        self.stored_hash
    }

    /// All chunks in file order, `End` excluded.
    pub fn chunks(&self) -> &[ChunkInfo] {
        &self.chunks
    }

    pub fn frame_count(&self) -> u32 {
        self.frame_chunks.len() as u32
    }

    /// Decodes and cross-checks the static chunks.
    pub fn scene(&mut self) -> Result<Scene> {
        let index = |kind| {
            self.chunks
                .iter()
                .position(|c| c.kind == kind)
                .expect("chunk order checked at open")
        };
        let (g, m, t, l) = (
            index(ChunkKind::Geometry),
            index(ChunkKind::Materials),
            index(ChunkKind::Textures),
            index(ChunkKind::Lights),
        );
        let scene = Scene {
            geometry: self.decode_chunk::<Geometry>(g)?,
            materials: self.decode_chunk::<Vec<Material>>(m)?,
            textures: self.decode_chunk::<Vec<Texture>>(t)?,
            lights: self.decode_chunk::<Vec<Light>>(l)?,
            surface_maps: match self.chunks.iter().position(|c| c.kind == ChunkKind::SurfaceMaps) {
                Some(s) => self.decode_chunk::<SurfaceMaps>(s)?,
                None => SurfaceMaps::default(),
            },
        };
        validate::check_scene(&scene, &self.meta.counts)?;
        Ok(scene)
    }

    /// Decodes frame `index` alone.
    pub fn frame(&mut self, index: u32) -> Result<Frame> {
        let chunk = *self.frame_chunks.get(index as usize).ok_or(Error::FrameOutOfRange {
            index,
            count: self.frame_count(),
        })?;
        let frame: Frame = self.decode_chunk(chunk)?;
        if frame.index != index {
            return Err(Error::Corrupt(format!(
                "frame chunk {index} says it is frame {}",
                frame.index
            )));
        }
        validate::check_frame(&frame, &self.meta.counts)?;
        Ok(frame)
    }

    /// Decompresses every chunk and checks the content hash against the `End` chunk.
    /// Chunks are hashed as they decompress, a block at a time, so memory stays flat.
    pub fn verify(&mut self) -> Result<ContentHash> {
        let mut hasher = ContentHasher::default();
        let mut block = vec![0u8; STREAM_BLOCK];
        for &info in &self.chunks {
            hasher.begin_chunk(info.kind.code(), info.raw_len);
            let mut decoder = chunk_decoder(&mut self.src, info)?;
            let mut total = 0u64;
            loop {
                let n = decoder.read(&mut block).map_err(|e| decompress_error(info, e))?;
                if n == 0 {
                    break;
                }
                total += n as u64;
                if total > info.raw_len {
                    break;
                }
                hasher.update(&block[..n]);
            }
            check_raw_len(info, total)?;
        }
        let computed = hasher.finish();
        if computed != self.stored_hash {
            return Err(Error::HashMismatch {
                stored: self.stored_hash.to_hex(),
                computed: computed.to_hex(),
            });
        }
        Ok(computed)
    }

    /// The decompressed bytes of chunk `i` (an index into [`TraceReader::chunks`]).
    pub fn raw_chunk(&mut self, i: usize) -> Result<Vec<u8>> {
        read_raw(&mut self.src, self.chunks[i])
    }

    fn decode_chunk<T: DeserializeOwned>(&mut self, i: usize) -> Result<T> {
        let raw = self.raw_chunk(i)?;
        decode(self.chunks[i].kind, &raw)
    }
}

/// A streaming decoder of one chunk's payload: the compressed bytes are read from the file
/// as they are needed, never whole.
fn chunk_decoder<R: Read + Seek>(src: &mut R, info: ChunkInfo) -> Result<impl Read + '_> {
    src.seek(SeekFrom::Start(info.offset))?;
    let packed = std::io::BufReader::with_capacity(STREAM_BLOCK, src.take(info.packed_len));
    let decoder = zstd::stream::read::Decoder::with_buffer(packed)
        .map_err(|e| decompress_error(info, e))?
        .single_frame();
    // One byte more than declared, to tell "longer than the header says" from "exact".
    Ok(decoder.take(info.raw_len + 1))
}

fn decompress_error(info: ChunkInfo, e: std::io::Error) -> Error {
    Error::Decompress {
        kind: info.kind,
        msg: e.to_string(),
    }
}

fn check_raw_len(info: ChunkInfo, got: u64) -> Result<()> {
    if got == info.raw_len {
        return Ok(());
    }
    let got = if got > info.raw_len {
        format!("more than {}", info.raw_len)
    } else {
        got.to_string()
    };
    Err(Error::Corrupt(format!(
        "{} chunk decompresses to {got} bytes, header says {}",
        info.kind, info.raw_len
    )))
}

/// Reads and decompresses one chunk, its length checked against its header. The declared
/// length was bounded when the chunk was indexed, and the output buffer grows with real
/// output rather than with the declared length.
fn read_raw<R: Read + Seek>(src: &mut R, info: ChunkInfo) -> Result<Vec<u8>> {
    let mut raw = Vec::with_capacity(info.raw_len.min(INITIAL_DECOMPRESS_CAPACITY) as usize);
    chunk_decoder(src, info)?
        .read_to_end(&mut raw)
        .map_err(|e| decompress_error(info, e))?;
    check_raw_len(info, raw.len() as u64)?;
    Ok(raw)
}

/// Reads chunk headers from `pos` to the `End` chunk, checking every length against the
/// bytes left in the file and every decompressed length against [`decompressed_limit`].
fn index_chunks<R: Read + Seek>(src: &mut R, mut pos: u64, file_len: u64) -> Result<(Vec<ChunkInfo>, ContentHash)> {
    let mut chunks = Vec::new();
    let mut raw_total = 0u64;
    loop {
        let left = file_len - pos;
        if left == 0 {
            return Err(Error::Truncated(format!(
                "file ends after {} chunks without an End chunk",
                chunks.len()
            )));
        }
        if left < CHUNK_HEADER_LEN {
            return Err(Error::Truncated(format!(
                "file ends inside a chunk header at byte {pos}"
            )));
        }
        src.seek(SeekFrom::Start(pos))?;
        let mut header = [0u8; CHUNK_HEADER_LEN as usize];
        src.read_exact(&mut header)?;
        let kind = ChunkKind::from_code(u32::from_le_bytes(header[0..4].try_into().expect("4")));
        let raw_len = u64::from_le_bytes(header[4..12].try_into().expect("8"));
        let packed_len = u64::from_le_bytes(header[12..20].try_into().expect("8"));
        let offset = pos + CHUNK_HEADER_LEN;
        let available = file_len - offset;
        if raw_len > MAX_CHUNK_RAW_LEN {
            return Err(Error::Oversized {
                kind,
                offset: pos,
                len: raw_len,
                limit: MAX_CHUNK_RAW_LEN,
            });
        }
        if packed_len > available {
            return Err(Error::Truncated(format!(
                "{kind} chunk at byte {pos} declares {packed_len} bytes, only {available} remain"
            )));
        }
        if kind != ChunkKind::End {
            let limit = decompressed_limit(packed_len);
            if raw_len > limit {
                return Err(Error::Expansion {
                    kind,
                    offset: pos,
                    raw_len,
                    packed_len,
                    limit,
                });
            }
            raw_total += raw_len;
            if raw_total > decompressed_limit(file_len) {
                return Err(Error::Corrupt(format!(
                    "chunks up to the {kind} chunk at byte {pos} decompress to {raw_total} bytes, \
                     more than the {} a {file_len}-byte file may hold",
                    decompressed_limit(file_len)
                )));
            }
        }
        if kind == ChunkKind::End {
            if raw_len != HASH_LEN || packed_len != HASH_LEN {
                return Err(Error::Corrupt(format!(
                    "End chunk at byte {pos} has lengths {raw_len}/{packed_len}, expected 32"
                )));
            }
            if available != HASH_LEN {
                return Err(Error::Corrupt(format!(
                    "{} bytes after the End chunk",
                    available - HASH_LEN
                )));
            }
            let mut hash = [0u8; HASH_LEN as usize];
            src.read_exact(&mut hash)?;
            return Ok((chunks, ContentHash(hash)));
        }
        chunks.push(ChunkInfo {
            kind,
            offset,
            raw_len,
            packed_len,
        });
        pos = offset + packed_len;
    }
}

/// Checks `Meta Geometry Materials Textures Lights SurfaceMaps? Frame*` (unknown kinds
/// anywhere after `Meta`) and returns the chunk index of every frame.
fn check_order(chunks: &[ChunkInfo]) -> Result<Vec<usize>> {
    const STATIC: [ChunkKind; 5] = [
        ChunkKind::Meta,
        ChunkKind::Geometry,
        ChunkKind::Materials,
        ChunkKind::Textures,
        ChunkKind::Lights,
    ];
    if chunks.first().map(|c| c.kind) != Some(ChunkKind::Meta) {
        return Err(Error::Corrupt("first chunk is not Meta".into()));
    }
    let mut next_static = 0;
    let mut frames = Vec::new();
    let mut surface_maps_seen = false;
    for (i, chunk) in chunks.iter().enumerate() {
        match chunk.kind {
            ChunkKind::Unknown(_) => {}
            ChunkKind::SurfaceMaps => {
                if next_static < STATIC.len() || !frames.is_empty() || surface_maps_seen {
                    return Err(Error::Corrupt(format!("unexpected SurfaceMaps chunk at position {i}")));
                }
                surface_maps_seen = true;
            }
            ChunkKind::Frame => {
                if next_static < STATIC.len() {
                    return Err(Error::Corrupt(format!(
                        "Frame chunk before the {} chunk",
                        STATIC[next_static]
                    )));
                }
                frames.push(i);
            }
            kind => {
                if STATIC.get(next_static) != Some(&kind) {
                    return Err(Error::Corrupt(format!("unexpected {kind} chunk at position {i}")));
                }
                next_static += 1;
            }
        }
    }
    if let Some(missing) = STATIC.get(next_static) {
        return Err(Error::Corrupt(format!("missing {missing} chunk")));
    }
    Ok(frames)
}
