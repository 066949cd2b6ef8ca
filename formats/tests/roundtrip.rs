//! Round trips: what is written is read back bit for bit, by frame and in one go, and the
//! content hash does not depend on the compression level.

mod common;

use std::io::Cursor;

use common::*;
use glam::{Vec2, Vec3};
use proptest::prelude::*;
use shadetrace_formats::*;

#[test]
fn sample_round_trips() {
    let scene = sample_scene();
    let frames: Vec<Frame> = (0..3).map(sample_frame).collect();
    let meta = meta_for(&scene, 3);
    let (bytes, hash) = write_trace(&meta, &scene, &frames, 3);
    let decoded = read_all(&bytes).unwrap();
    assert_eq!(decoded.meta, meta);
    assert_eq!(decoded.scene, scene);
    assert_eq!(decoded.frames, frames);
    assert_eq!(decoded.hash, hash);
}

/// A scene with surface maps is written as format minor 1 with its `SurfaceMaps` chunk and
/// reads back whole; without maps the file stays minor 0, as it was before the chunk.
#[test]
fn surface_maps_round_trip_in_minor_1_only() {
    let frames: Vec<Frame> = (0..2).map(sample_frame).collect();
    for (scene, minor) in [(sample_scene(), 0u16), (sample_scene_with_maps(), 1)] {
        let meta = meta_for(&scene, 2);
        let (bytes, _) = write_trace(&meta, &scene, &frames, 3);
        assert_eq!(u16::from_le_bytes([bytes[6], bytes[7]]), minor);
        let decoded = read_all(&bytes).unwrap();
        assert_eq!(decoded.scene, scene);
    }
    // Tangents must match the normal maps.
    let mut bad = sample_scene_with_maps();
    bad.surface_maps.tangents[0].pop();
    let meta = meta_for(&bad, 2);
    assert!(TraceWriter::new(Vec::new(), 3, &meta, &bad).is_err());
    // No normal map on a skinned mesh (frames carry no skinned tangents).
    let mut skinned = sample_scene_with_maps();
    skinned.geometry.meshes[2].material = 0;
    skinned.surface_maps.tangents[2] = vec![glam::Vec4::new(1.0, 0.0, 0.0, 1.0); 4];
    assert!(TraceWriter::new(Vec::new(), 3, &meta_for(&skinned, 2), &skinned).is_err());
    // A chunk without a single map is not what a writer writes, and not accepted.
    let mut empty = sample_scene_with_maps();
    empty.surface_maps.materials = vec![MaterialMaps::NONE; 2];
    empty.surface_maps.tangents = vec![vec![]; 3];
    assert!(TraceWriter::new(Vec::new(), 3, &meta_for(&empty, 2), &empty).is_err());
}

#[test]
fn compression_level_does_not_change_the_hash() {
    let scene = sample_scene();
    let frames: Vec<Frame> = (0..3).map(sample_frame).collect();
    let meta = meta_for(&scene, 3);
    let (fast, h1) = write_trace(&meta, &scene, &frames, 1);
    let (small, h19) = write_trace(&meta, &scene, &frames, 19);
    assert_eq!(h1, h19);
    assert_eq!(read_all(&fast).unwrap().hash, read_all(&small).unwrap().hash);
}

#[test]
fn seeks_to_a_frame_without_decoding_the_others() {
    let mut bytes = sample_trace();
    // Corrupt frame 1's payload: frames 0 and 2 must still read.
    let reader = TraceReader::open(Cursor::new(&bytes)).unwrap();
    let frame_chunks: Vec<ChunkInfo> = reader
        .chunks()
        .iter()
        .filter(|c| c.kind == ChunkKind::Frame)
        .copied()
        .collect();
    let middle = frame_chunks[1];
    let at = (middle.offset + middle.packed_len / 2) as usize;
    bytes[at] ^= 0xff;
    let mut reader = TraceReader::open(Cursor::new(&bytes)).unwrap();
    assert_eq!(reader.frame(0).unwrap(), sample_frame(0));
    assert_eq!(reader.frame(2).unwrap(), sample_frame(2));
    assert!(reader.frame(1).is_err());
    assert!(matches!(
        reader.frame(3),
        Err(Error::FrameOutOfRange { index: 3, count: 3 })
    ));
}

#[test]
fn documented_hash_matches_a_hand_assembled_file() {
    let bytes = sample_trace();
    let hand = assemble(FORMAT_MAJOR, FORMAT_MINOR, &raw_chunks(&bytes));
    assert_eq!(read_all(&hand).unwrap().hash, read_all(&bytes).unwrap().hash);
}

#[test]
fn writer_rejects_inconsistent_input() {
    let scene = sample_scene();
    let meta = meta_for(&scene, 2);
    let mut writer = TraceWriter::new(Vec::new(), 1, &meta, &scene).unwrap();
    assert!(writer.write_frame(&sample_frame(1)).is_err(), "out of order");
    writer.write_frame(&sample_frame(0)).unwrap();
    assert!(writer.finish().is_err(), "missing frame");

    let mut bad = scene.clone();
    bad.geometry.meshes[0].positions[1] = Vec3::new(f32::NAN, 0.0, 0.0);
    assert!(matches!(
        TraceWriter::new(Vec::new(), 1, &meta, &bad),
        Err(Error::Invalid(_))
    ));
    let mut bad = scene.clone();
    bad.geometry.meshes[0].indices[2] = 99;
    let err = TraceWriter::new(Vec::new(), 1, &meta, &bad).err().unwrap().to_string();
    assert!(err.contains("index 99 out of range"), "{err}");
}

fn arb_vec3() -> impl Strategy<Value = Vec3> {
    (-1e6f32..1e6, -1e6f32..1e6, -1e6f32..1e6).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

prop_compose! {
    fn arb_mesh(materials: u32)(
        vertices in 1usize..24,
        material in 0..materials,
        textured in any::<bool>(),
        with_patches in any::<bool>(),
        name in "[a-z]{0,8}",
    )(
        positions in prop::collection::vec(arb_vec3(), vertices),
        normals in prop::collection::vec(arb_vec3(), vertices),
        uvs in prop::collection::vec((-4f32..4.0, -4f32..4.0).prop_map(|(u, v)| Vec2::new(u, v)), if textured { vertices } else { 0 }),
        indices in prop::collection::vec(0..vertices as u32, 0..10).prop_map(|t| t.into_iter().flat_map(|i| [i, i, i]).collect::<Vec<u32>>()),
        material in Just(material),
        with_patches in Just(with_patches),
        name in Just(name),
    ) -> Mesh {
        let patch_ids = if with_patches { (0..indices.len() as u32 / 3).collect() } else { vec![] };
        let uv_atlas_unique = !uvs.is_empty();
        Mesh { name, material, motion: Motion::Static, positions, normals, uvs, indices, patch_ids, uv_atlas_unique }
    }
}

prop_compose! {
    fn arb_scene()(meshes in prop::collection::vec(arb_mesh(2), 0..5), tex in 1u32..5, level in 1i32..10)
        (texture in prop::collection::vec(any::<u8>(), (tex * tex * 4) as usize), meshes in Just(meshes), tex in Just(tex), level in Just(level))
        -> (Scene, i32)
    {
        let mut scene = sample_scene();
        scene.geometry.meshes = meshes;
        scene.textures[0] = Texture { name: "t".into(), width: tex, height: tex, wrap_u: Wrap::MirroredRepeat, wrap_v: Wrap::Repeat, rgba8: texture };
        (scene, level)
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn arbitrary_scenes_round_trip((scene, level) in arb_scene(), frames in 0u32..4) {
        let meta = meta_for(&scene, frames);
        let frames: Vec<Frame> = (0..frames)
            .map(|i| Frame { rigid_transforms: vec![], skinned: vec![], ..sample_frame(i) })
            .collect();
        let (bytes, hash) = write_trace(&meta, &scene, &frames, level);
        let decoded = read_all(&bytes).unwrap();
        prop_assert_eq!(decoded.hash, hash);
        prop_assert_eq!(decoded.meta, meta);
        prop_assert_eq!(decoded.scene, scene);
        prop_assert_eq!(decoded.frames, frames);
    }
}
