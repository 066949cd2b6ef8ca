//! Malformed files: every one is a clear `Error`, never a panic, never silently wrong data,
//! and never an allocation sized by a length the file cannot back.

mod common;

use std::io::Cursor;

use common::*;
use shadetrace_formats::*;

#[test]
fn every_truncation_point_is_an_error() {
    let bytes = sample_trace();
    for len in 0..bytes.len() {
        let result = read_all(&bytes[..len]);
        assert!(
            result.is_err(),
            "truncated to {len} of {} bytes was accepted",
            bytes.len()
        );
    }
}

#[test]
fn flipped_bytes_never_give_wrong_data() {
    let bytes = sample_trace();
    let good = read_all(&bytes).unwrap();
    let mut accepted = Vec::new();
    for at in 0..bytes.len() {
        for mask in [0x01u8, 0x80, 0xff] {
            let mut bad = bytes.clone();
            bad[at] ^= mask;
            if let Ok(decoded) = read_all(&bad) {
                assert_eq!(
                    decoded, good,
                    "flip at byte {at} (mask {mask:#x}) changed the decoded trace"
                );
                accepted.push(at);
            }
        }
    }
    // Only the minor version (a newer minor is readable by design) and bits zstd ignores
    // may be flipped harmlessly.
    assert!(accepted.len() < bytes.len() / 10, "{} harmless flips", accepted.len());
    assert!(accepted.contains(&6), "a newer minor version must be accepted");
}

#[test]
fn wrong_magic() {
    let mut bytes = sample_trace();
    bytes[0..4].copy_from_slice(b"GLTF");
    let err = read_all(&bytes).unwrap_err();
    assert!(matches!(err, Error::BadMagic(_)));
    assert!(err.to_string().contains("not a shadetrace trace"));
}

#[test]
fn newer_major_is_refused_newer_minor_with_unknown_chunks_is_read() {
    let bytes = sample_trace();
    let chunks = raw_chunks(&bytes);
    let newer_major = assemble(FORMAT_MAJOR + 1, 0, &chunks);
    let err = read_all(&newer_major).unwrap_err();
    assert!(matches!(err, Error::NewerMajor { .. }), "{err}");
    assert!(err.to_string().contains("newer"), "{err}");

    // A newer minor may add chunk kinds; this reader skips them (but hashes them).
    let mut with_unknown = chunks.clone();
    with_unknown.insert(3, (0x77, b"from the future".to_vec()));
    with_unknown.push((0x78, vec![1, 2, 3]));
    let newer_minor = assemble(FORMAT_MAJOR, FORMAT_MINOR + 3, &with_unknown);
    let decoded = read_all(&newer_minor).unwrap();
    assert_eq!(decoded.scene, read_all(&bytes).unwrap().scene);
    assert_eq!(
        TraceReader::open(Cursor::new(&newer_minor)).unwrap().version(),
        (FORMAT_MAJOR, FORMAT_MINOR + 3)
    );
}

/// Offset of the header of chunk `i`.
fn header_offset(bytes: &[u8], i: usize) -> usize {
    let reader = TraceReader::open(Cursor::new(bytes)).unwrap();
    reader.chunks()[i].offset as usize - 20
}

#[test]
fn absurd_lengths_are_refused_before_allocating() {
    let bytes = sample_trace();
    let geometry = header_offset(&bytes, 1);
    for (field, value) in [(4, u64::MAX), (4, 1 << 40), (12, u64::MAX), (12, 1 << 40), (4, 3 << 30)] {
        let mut bad = bytes.clone();
        bad[geometry + field..geometry + field + 8].copy_from_slice(&value.to_le_bytes());
        let err = read_all(&bad).unwrap_err();
        let msg = err.to_string();
        assert!(
            matches!(
                err,
                Error::Oversized { .. } | Error::Expansion { .. } | Error::Truncated(_) | Error::Corrupt(_)
            ),
            "field {field} = {value}: {msg}"
        );
    }
}

#[test]
fn payload_claiming_huge_collections_is_a_decode_error() {
    let bytes = sample_trace();
    let mut chunks = raw_chunks(&bytes);
    // bincode varint 253 = "u64 follows": the meshes vector claims 2^60 elements.
    let mut huge = vec![253u8];
    huge.extend_from_slice(&(1u64 << 60).to_le_bytes());
    chunks[1].1 = huge;
    let err = read_all(&assemble(FORMAT_MAJOR, FORMAT_MINOR, &chunks)).unwrap_err();
    assert!(
        matches!(
            err,
            Error::Decode {
                kind: ChunkKind::Geometry,
                ..
            }
        ),
        "{err}"
    );
}

#[test]
fn structural_errors() {
    let bytes = sample_trace();
    let chunks = raw_chunks(&bytes);
    let cases: Vec<(&str, Vec<RawChunk>)> = vec![
        (
            "missing Lights",
            chunks
                .iter()
                .filter(|c| c.0 != ChunkKind::Lights.code())
                .cloned()
                .collect(),
        ),
        ("no Meta first", chunks[1..].to_vec()),
        ("frame count", chunks[..chunks.len() - 1].to_vec()),
        ("duplicate Geometry", {
            let mut c = chunks.clone();
            c.insert(2, chunks[1].clone());
            c
        }),
        ("trailing payload bytes", {
            let mut c = chunks.clone();
            c[2].1.push(0);
            c
        }),
    ];
    for (what, chunks) in cases {
        let err = read_all(&assemble(FORMAT_MAJOR, FORMAT_MINOR, &chunks));
        assert!(err.is_err(), "{what} accepted");
    }
    let mut extra = bytes.clone();
    extra.push(0);
    assert!(read_all(&extra)
        .unwrap_err()
        .to_string()
        .contains("after the End chunk"));
}

#[test]
fn invalid_content_is_refused_on_read() {
    // A hand-made file whose geometry references a vertex that does not exist.
    let bytes = sample_trace();
    let mut chunks = raw_chunks(&bytes);
    let mut scene = sample_scene();
    scene.geometry.meshes[0].indices[0] = 1000;
    chunks[1].1 = bincode::serde::encode_to_vec(&scene.geometry, bincode::config::standard()).unwrap();
    let err = read_all(&assemble(FORMAT_MAJOR, FORMAT_MINOR, &chunks)).unwrap_err();
    assert!(err.to_string().contains("out of range"), "{err}");
}

#[test]
fn messages_are_one_line() {
    let bytes = sample_trace();
    for len in [0, 5, 13, bytes.len() / 2, bytes.len() - 1] {
        let msg = read_all(&bytes[..len]).unwrap_err().to_string();
        assert!(!msg.contains('\n') && !msg.is_empty(), "{msg:?}");
    }
}
