//! Decompression bombs: small files whose chunks inflate far beyond what their size
//! justifies are refused at open, before anything is decompressed.

mod common;

use std::io::{Cursor, Write};

use common::*;
use shadetrace_formats::container::MAX_CHUNK_RAW_LEN;
use shadetrace_formats::{decompressed_limit, ChunkKind, Error, TraceReader, EXPANSION_ALLOWANCE, MAX_EXPANSION};

/// A zstd frame of `len` zero bytes, compressed as it is generated (never held whole).
fn zeros_frame(len: u64) -> Vec<u8> {
    let mut encoder = zstd::stream::Encoder::new(Vec::new(), 1).expect("encoder");
    encoder.set_pledged_src_size(Some(len)).expect("pledge");
    let block = vec![0u8; 1 << 20];
    let mut left = len;
    while left > 0 {
        let n = left.min(block.len() as u64) as usize;
        encoder.write_all(&block[..n]).expect("compress");
        left -= n as u64;
    }
    encoder.finish().expect("finish")
}

/// `chunks` with `bombs` inserted before position `at`, each `(kind, raw_len)` a real
/// zstd frame of that many zeros. The content hash is left wrong: the reader must refuse
/// the file before it could ever check it.
fn with_bombs(chunks: &[RawChunk], at: usize, bombs: &[(u32, u64)]) -> Vec<u8> {
    let mut out = assemble(1, 0, &chunks[..at]);
    out.truncate(out.len() - 52); // drop the End chunk
    for &(kind, raw_len) in bombs {
        let packed = zeros_frame(raw_len);
        out.extend_from_slice(&kind.to_le_bytes());
        out.extend_from_slice(&raw_len.to_le_bytes());
        out.extend_from_slice(&(packed.len() as u64).to_le_bytes());
        out.extend_from_slice(&packed);
    }
    let tail = assemble(1, 0, &chunks[at..]);
    out.extend_from_slice(&tail[12..]);
    out
}

#[test]
fn an_unknown_chunk_inflating_to_gigabytes_is_refused_at_open() {
    let chunks = raw_chunks(&sample_trace());
    let bomb = with_bombs(&chunks, 2, &[(0x77, 1 << 30)]);
    assert!(bomb.len() < 1 << 20, "the bomb is small: {} bytes", bomb.len());
    let err = TraceReader::open(Cursor::new(&bomb)).err().expect("refused");
    assert!(
        matches!(
            err,
            Error::Expansion {
                kind: ChunkKind::Unknown(0x77),
                ..
            }
        ),
        "{err}"
    );
    let msg = err.to_string();
    assert!(
        msg.contains("Unknown(0x77) chunk") && msg.contains("decompression bomb"),
        "{msg}"
    );
}

#[test]
fn a_textures_chunk_inflating_past_the_limit_is_refused_and_three_bombs_too() {
    let chunks = raw_chunks(&sample_trace());
    // chunks: Meta Geometry Materials Textures Lights Frame...: replace Textures.
    let mut without_textures = chunks.clone();
    let textures = without_textures.remove(3);
    assert_eq!(textures.0, ChunkKind::Textures.code());
    let bomb = with_bombs(&without_textures, 3, &[(ChunkKind::Textures.code(), 256 << 20)]);
    let err = read_all(&bomb).unwrap_err();
    assert!(
        matches!(
            err,
            Error::Expansion {
                kind: ChunkKind::Textures,
                ..
            }
        ),
        "{err}"
    );

    let three = with_bombs(&chunks, 5, &[(0x70, 48 << 20), (0x71, 48 << 20), (0x72, 48 << 20)]);
    let err = read_all(&three).unwrap_err();
    assert!(
        matches!(&err, Error::Corrupt(msg) if msg.contains("decompress to") && msg.contains("Unknown(0x71)")),
        "each chunk is under the allowance, together they are over it: {err}"
    );
}

#[test]
fn the_limit_is_stated_and_generous_for_real_traces() {
    assert_eq!(decompressed_limit(0), EXPANSION_ALLOWANCE);
    assert_eq!(decompressed_limit(1 << 16), EXPANSION_ALLOWANCE);
    assert_eq!(decompressed_limit(1 << 24), MAX_EXPANSION << 24);
    assert_eq!(
        decompressed_limit(1 << 30),
        MAX_CHUNK_RAW_LEN,
        "never above the per-chunk cap"
    );
    // A highly compressible but small chunk under the allowance reads back.
    let mut chunks = raw_chunks(&sample_trace());
    chunks.insert(5, (0x79, vec![0u8; 8 << 20]));
    let decoded = read_all(&assemble(1, 0, &chunks)).expect("a 8 MiB run of zeros is fine");
    assert_eq!(decoded.scene, read_all(&sample_trace()).unwrap().scene);
}

#[test]
fn verify_streams_every_chunk_and_catches_a_changed_unknown_chunk() {
    let mut chunks = raw_chunks(&sample_trace());
    chunks.insert(5, (0x79, vec![7u8; 3 << 20]));
    let good = assemble(1, 0, &chunks);
    TraceReader::open(Cursor::new(&good))
        .unwrap()
        .verify()
        .expect("hash matches");
    // Same lengths, one byte different inside the unknown chunk: the stored hash no longer matches.
    let mut changed = chunks.clone();
    changed[5].1[1 << 20] = 8;
    let mut bad = assemble(1, 0, &changed);
    let end = bad.len() - 32;
    bad[end..].copy_from_slice(&good[good.len() - 32..]);
    let err = TraceReader::open(Cursor::new(&bad)).unwrap().verify().unwrap_err();
    assert!(matches!(err, Error::HashMismatch { .. }), "{err}");
}
