//! Compressed glTF (Draco, meshopt, KTX2 textures) captures to the triangles and texels
//! of its uncompressed source, within the encoders' quantization.
//!
//! The fixtures in `tests/fixtures/` were made from [`support::write_wavy_grid_glb`] by
//! the tools people use (`scripts/make-compressed-fixtures.sh`: gltfpack, gltf-transform
//! and Basis Universal's encoder), so these tests check our decoders against theirs, not
//! against themselves.

mod support;

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};
use shadetrace_capture::gltf_import::{load_gltf, ImportLimits, ImportOptions};
use shadetrace_capture::source::SourceScene;

const OPTS: ImportOptions = ImportOptions {
    max_texture: 2048,
    limits: ImportLimits::DEFAULT,
};

fn load(path: &Path) -> SourceScene {
    load_gltf(path, &OPTS).unwrap_or_else(|e| panic!("{e}"))
}

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures").join(name)
}

/// One triangle of a captured scene: its corners, their UVs, and its texture's texels.
#[derive(Clone, Copy)]
struct Triangle<'a> {
    corners: [Vec3; 3],
    uvs: [Vec2; 3],
    texels: Option<&'a [u8]>,
}

fn triangles(scene: &SourceScene) -> Vec<Triangle<'_>> {
    let mut out = Vec::new();
    for mesh in &scene.scene.geometry.meshes {
        let material = &scene.scene.materials[mesh.material as usize];
        let texels = material
            .base_color_texture
            .map(|t| scene.scene.textures[t as usize].rgba8.as_slice());
        for t in mesh.indices.chunks_exact(3) {
            let corner = |k: usize| mesh.positions[t[k] as usize];
            let uv = |k: usize| mesh.uvs.get(t[k] as usize).copied().unwrap_or(Vec2::ZERO);
            out.push(Triangle {
                corners: [corner(0), corner(1), corner(2)],
                uvs: [uv(0), uv(1), uv(2)],
                texels,
            });
        }
    }
    out
}

/// How far a variant's triangles are from the source's.
#[derive(Debug, Default)]
pub struct Match {
    pub unmatched: usize,
    pub max_position_error: f32,
    pub max_uv_error: f32,
    pub texel_mismatches: usize,
}

/// Pairs every triangle of `variant` with a triangle of `source` whose corners (in the
/// same winding, any rotation) are within `tolerance`, whatever the triangle and vertex
/// order: encoders reorder both.
fn match_triangles(source: &SourceScene, variant: &SourceScene, tolerance: f32) -> Match {
    let source = triangles(source);
    let variant = triangles(variant);
    let cell = 4.0 * tolerance;
    let key = |p: Vec3| (p / cell).floor().as_ivec3().to_array();
    let centroid = |t: &Triangle| (t.corners[0] + t.corners[1] + t.corners[2]) / 3.0;
    let mut grid: HashMap<[i32; 3], Vec<usize>> = HashMap::new();
    for (i, t) in source.iter().enumerate() {
        grid.entry(key(centroid(t))).or_default().push(i);
    }
    let mut used = vec![false; source.len()];
    let mut result = Match {
        unmatched: source.len().abs_diff(variant.len()),
        ..Match::default()
    };
    for t in &variant {
        let [x, y, z] = key(centroid(t));
        let mut best: Option<(usize, usize, f32)> = None;
        for (dx, dy, dz) in (-1..=1).flat_map(|a| (-1..=1).flat_map(move |b| (-1..=1).map(move |c| (a, b, c)))) {
            for &i in grid.get(&[x + dx, y + dy, z + dz]).into_iter().flatten() {
                if used[i] {
                    continue;
                }
                for rotation in 0..3 {
                    let error = (0..3)
                        .map(|k| source[i].corners[(k + rotation) % 3].distance(t.corners[k]))
                        .fold(0.0, f32::max);
                    if error <= tolerance && best.is_none_or(|b| error < b.2) {
                        best = Some((i, rotation, error));
                    }
                }
            }
        }
        let Some((i, rotation, error)) = best else {
            result.unmatched += 1;
            continue;
        };
        used[i] = true;
        result.max_position_error = result.max_position_error.max(error);
        for k in 0..3 {
            let uv_error = source[i].uvs[(k + rotation) % 3].distance(t.uvs[k]);
            result.max_uv_error = result.max_uv_error.max(uv_error);
        }
        if source[i].texels != t.texels {
            result.texel_mismatches += 1;
        }
    }
    result
}

/// The source scene, written afresh.
fn source() -> (tempfile::TempDir, SourceScene) {
    let dir = tempfile::tempdir().unwrap();
    let scene = load(&support::write_wavy_grid_glb(dir.path()));
    (dir, scene)
}

/// The grid spans 2 m; 14-bit positions (both tools' default) are 2 / 16383 m apart, and
/// 12-bit UVs 1 / 4095 apart: allow one step.
const POSITION_STEP: f32 = 2.0 / 16383.0;
const UV_STEP: f32 = 1.0 / 4095.0;

fn assert_same_as_source(name: &str) {
    let (_dir, source) = source();
    let variant = load(&fixture(name));
    let triangles = variant
        .scene
        .geometry
        .meshes
        .iter()
        .map(|m| m.triangle_count())
        .sum::<usize>();
    assert_eq!(triangles, 512, "{name}");
    let m = match_triangles(&source, &variant, POSITION_STEP);
    assert_eq!(m.unmatched, 0, "{name}: {m:?}");
    assert_eq!(m.texel_mismatches, 0, "{name}: {m:?}");
    assert!(m.max_uv_error <= UV_STEP, "{name}: {m:?}");
    // Normals survive within their 8- to 10-bit quantization.
    for mesh in &variant.scene.geometry.meshes {
        assert!(
            mesh.normals
                .iter()
                .all(|n| (n.length() - 1.0).abs() < 1e-3 && n.y > 0.5),
            "{name}"
        );
    }
}

#[test]
fn draco_from_gltf_transform_matches_its_source() {
    assert_same_as_source("wavy_grid-draco.glb");
}

#[test]
fn meshopt_from_gltfpack_matches_its_source() {
    assert_same_as_source("wavy_grid-meshopt.glb");
}

#[test]
fn meshopt_with_filters_from_gltf_transform_matches_its_source() {
    assert_same_as_source("wavy_grid-meshopt-filters.glb");
}

/// A KTX2 variant has the source's triangles, and its texels are exactly what Basis
/// Universal's own transcoder decodes (the PNG beside it): Basis is lossy, so the source's
/// texels are not the reference.
fn assert_basis_variant(codec: &str) {
    let (_dir, source) = source();
    let variant = load(&fixture(&format!("wavy_grid-{codec}.glb")));
    let m = match_triangles(&source, &variant, 1e-6);
    assert_eq!((m.unmatched, m.max_uv_error), (0, 0.0), "{codec}: {m:?}");
    let reference = image::open(fixture(&format!("wavy_grid-{codec}.png")))
        .unwrap()
        .into_rgba8();
    let texture = &variant.scene.textures[0];
    assert_eq!((texture.width, texture.height), reference.dimensions(), "{codec}");
    assert_eq!(texture.rgba8, reference.into_raw(), "{codec}");
}

#[test]
fn ktx2_etc1s_textures_decode_as_basis_universal_does() {
    assert_basis_variant("etc1s");
}

#[test]
fn ktx2_uastc_zstd_textures_decode_as_basis_universal_does() {
    assert_basis_variant("uastc");
}

#[test]
fn the_matcher_tells_a_moved_triangle() {
    let (_dir, source) = source();
    let mut moved = load(&fixture("wavy_grid-meshopt.glb"));
    let mesh = &mut moved.scene.geometry.meshes[0];
    let first = mesh.indices[0] as usize;
    mesh.positions[first].y += 10.0 * POSITION_STEP;
    let m = match_triangles(&source, &moved, POSITION_STEP);
    assert!(m.unmatched > 0, "{m:?}");
}

/// The largest mean absolute texel difference over the textures of two scenes with the
/// same textures in the same order and sizes.
fn texel_difference(a: &SourceScene, b: &SourceScene) -> String {
    let (a, b) = (&a.scene.textures, &b.scene.textures);
    if a.len() != b.len() || a.iter().zip(b).any(|(a, b)| (a.width, a.height) != (b.width, b.height)) {
        return "textures differ in number or size".to_string();
    }
    let mean = |a: &[u8], b: &[u8]| {
        a.iter().zip(b).map(|(&x, &y)| f64::from(x.abs_diff(y))).sum::<f64>() / a.len().max(1) as f64
    };
    let worst = a
        .iter()
        .zip(b)
        .map(|(a, b)| mean(&a.rgba8, &b.rgba8))
        .fold(0.0, f64::max);
    format!("{} textures, largest mean texel difference {worst:.2} levels", a.len())
}

/// Writes the fixtures' source for `scripts/make-compressed-fixtures.sh`.
#[test]
#[ignore = "run by scripts/make-compressed-fixtures.sh"]
fn write_fixture_source() {
    let dir = std::env::var("SHADETRACE_FIXTURE_DIR").expect("SHADETRACE_FIXTURE_DIR");
    support::write_wavy_grid_glb(Path::new(&dir));
}

/// Compares a real scene with its compressed variants (`scripts/make-compressed-fixtures.sh
/// --scene`): `SHADETRACE_VARIANTS=source.glb,variant.glb,...`. Both tools quantize
/// positions to 14 bits by default, so the tolerance is one such step of the scene's
/// largest extent.
#[test]
#[ignore = "run by scripts/make-compressed-fixtures.sh --scene"]
fn compare_scene_variants() {
    let paths = std::env::var("SHADETRACE_VARIANTS").expect("SHADETRACE_VARIANTS");
    let mut paths = paths.split(',');
    let source = load(Path::new(paths.next().unwrap()));
    let corners = triangles(&source).into_iter().flat_map(|t| t.corners);
    let (lo, hi) = corners.fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
        (lo.min(p), hi.max(p))
    });
    let tolerance = (hi - lo).max_element() / 16383.0;
    println!("tolerance {tolerance:.3e} m");
    for path in paths {
        let variant = load(Path::new(path));
        let m = match_triangles(&source, &variant, tolerance);
        println!("{path}: {}", texel_difference(&source, &variant));
        println!(
            "{path}: {} triangles (source {}), {} unmatched, position error <= {:.3e} m, UV error <= {:.3e}, {} with other texels",
            triangles(&variant).len(),
            triangles(&source).len(),
            m.unmatched,
            m.max_position_error,
            m.max_uv_error,
            m.texel_mismatches
        );
    }
}

/// The byte range of a GLB's BIN chunk, where the compressed streams are.
fn bin_chunk(glb: &[u8]) -> std::ops::Range<usize> {
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    20 + json_len + 8..glb.len()
}

/// One byte edit on which draco-oxide panics (byte 1661 of the Draco stream, in its
/// attribute data): capture reports corrupt data instead.
#[test]
fn a_draco_decoder_panic_is_a_one_line_error() {
    let mut glb = std::fs::read(fixture("wavy_grid-draco.glb")).unwrap();
    let stream_start = bin_chunk(&glb).start + 168; // the Draco buffer view's byteOffset
    glb[stream_start + 1661] = 0xff;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("corrupt.glb");
    std::fs::write(&path, &glb).unwrap();
    let e = load_gltf(&path, &OPTS).err().expect("an error");
    let message = e.to_string();
    assert!(
        message.contains("corrupt.glb") && message.contains("corrupt Draco data"),
        "{message}"
    );
    assert!(!message.contains('\n'), "{message}");
}

/// Compressed geometry is charged to the import's budget before it is decoded: the grid's
/// few kilobytes of geometry fit 1 MiB and not 1 KiB, and the refusal names the stream.
#[test]
fn compressed_geometry_is_charged_before_it_is_decoded() {
    for (name, stream) in [
        ("wavy_grid-draco.glb", "(Draco)"),
        ("wavy_grid-meshopt.glb", "(meshopt compression)"),
    ] {
        let with = |geometry_bytes| ImportOptions {
            limits: ImportLimits {
                geometry_bytes,
                ..ImportLimits::DEFAULT
            },
            ..OPTS
        };
        assert!(load_gltf(&fixture(name), &with(1 << 20)).is_ok(), "{name}");
        let message = load_gltf(&fixture(name), &with(1 << 10))
            .err()
            .expect("refused")
            .to_string();
        assert!(message.contains(name) && message.contains(stream), "{message}");
        assert!(message.contains("1024 bytes of geometry"), "{message}");
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(96))]

    /// Corrupt Draco, meshopt and Basis streams are errors naming the file, never panics.
    #[test]
    fn corrupt_compressed_streams_are_errors_not_panics(
        fixture_index in 0usize..5,
        edits in proptest::collection::vec((proptest::sample::select(vec![0u8, 0xff, 0x7f, 0x80, 0x01]), proptest::prelude::any::<proptest::sample::Index>()), 1..8),
    ) {
        let name = ["draco", "meshopt", "meshopt-filters", "etc1s", "uastc"][fixture_index];
        let mut glb = std::fs::read(fixture(&format!("wavy_grid-{name}.glb"))).unwrap();
        let bin = bin_chunk(&glb);
        for (value, at) in edits {
            glb[bin.start + at.index(bin.len())] = value;
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("corrupt.glb");
        std::fs::write(&path, &glb).unwrap();
        if let Err(e) = load_gltf(&path, &OPTS) {
            let message = e.to_string();
            proptest::prop_assert!(message.contains("corrupt.glb") && !message.contains('\n'), "{message}");
        }
    }
}
