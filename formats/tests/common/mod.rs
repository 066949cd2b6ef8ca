//! Shared helpers: a small valid trace and a raw chunk assembler for hand-made files.

#![allow(dead_code)]

use std::io::Cursor;

use glam::{Mat4, Quat, Vec2, Vec3};
use sha2::{Digest, Sha256};
use shadetrace_formats::*;

pub fn rig() -> StereoRig {
    StereoRig {
        head: Pose {
            position: Vec3::new(0.0, 1.6, 3.0),
            orientation: Quat::IDENTITY,
        },
        ipd_m: 0.07,
        eye_width: 64,
        eye_height: 72,
        yfov: 1.5,
        near: 0.05,
        far: 50.0,
        convergence_m: 2.0,
    }
}

/// A scene with one static textured mesh, one rigid and one skinned mesh, two lights.
pub fn sample_scene() -> Scene {
    let quad = |name: &str, material: u32, motion: Motion, uvs: bool| Mesh {
        name: name.into(),
        material,
        motion,
        positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
        normals: vec![Vec3::Z; 4],
        uvs: if uvs {
            vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y]
        } else {
            vec![]
        },
        indices: vec![0, 1, 2, 0, 2, 3],
        patch_ids: vec![7, 7],
        uv_atlas_unique: uvs,
    };
    Scene {
        geometry: Geometry {
            meshes: vec![
                quad("static", 0, Motion::Static, true),
                quad("rigid", 1, Motion::Rigid { slot: 0 }, false),
                quad("skinned", 1, Motion::Skinned { slot: 0 }, false),
            ],
        },
        materials: vec![
            Material {
                name: "textured".into(),
                base_color: [1.0, 0.5, 0.25, 1.0],
                base_color_texture: Some(0),
                specular_exponent: 32.0,
                specular_strength: 0.04,
                alpha: AlphaMode::Mask { cutoff: 0.5 },
                double_sided: true,
            },
            Material {
                name: "plain".into(),
                base_color: [0.2, 0.3, 0.4, 1.0],
                base_color_texture: None,
                specular_exponent: 8.0,
                specular_strength: 1.0,
                alpha: AlphaMode::Opaque,
                double_sided: false,
            },
        ],
        textures: vec![Texture {
            name: "tex".into(),
            width: 2,
            height: 2,
            wrap_u: Wrap::Repeat,
            wrap_v: Wrap::ClampToEdge,
            rgba8: (0..16).collect(),
        }],
        lights: vec![
            Light {
                name: "sun".into(),
                kind: LightKind::Directional {
                    direction: Vec3::new(0.0, -1.0, 0.0),
                },
                color: Vec3::ONE,
                intensity: 3.0,
                shadowed: true,
            },
            Light {
                name: "lamp".into(),
                kind: LightKind::Point {
                    position: Vec3::new(0.0, 2.0, 0.0),
                    range: Some(5.0),
                },
                color: Vec3::new(1.0, 0.5, 0.5),
                intensity: 10.0,
                shadowed: false,
            },
        ],
        surface_maps: SurfaceMaps::default(),
    }
}

/// [`sample_scene`] with surface maps: a normal map and emission on the textured material
/// (its static mesh gets tangents), the texture marked as data.
pub fn sample_scene_with_maps() -> Scene {
    let mut scene = sample_scene();
    scene.surface_maps = SurfaceMaps {
        materials: vec![
            MaterialMaps {
                normal: Some((0, 0.5)),
                emissive: [1.0, 0.5, 0.0],
                emissive_texture: Some(0),
                ..MaterialMaps::NONE
            },
            MaterialMaps::NONE,
        ],
        tangents: vec![vec![glam::Vec4::new(1.0, 0.0, 0.0, -1.0); 4], vec![], vec![]],
        linear_textures: vec![0],
    };
    scene
}

pub fn sample_frame(index: u32) -> Frame {
    Frame {
        index,
        time_s: index as f32 / 30.0,
        rig: rig(),
        rigid_transforms: vec![Mat4::from_translation(Vec3::new(index as f32, 0.0, 0.0))],
        skinned: vec![SkinnedVertices {
            positions: vec![Vec3::splat(index as f32); 4],
            normals: vec![Vec3::Y; 4],
        }],
    }
}

pub fn meta_for(scene: &Scene, frames: u32) -> Meta {
    Meta {
        tool_version: "test".into(),
        scene_name: "sample".into(),
        source: Source::Builtin {
            name: "sample".into(),
            params: String::new(),
        },
        capture: CaptureSettings {
            frames,
            camera_path: "orbit".into(),
            ipd_m: 0.07,
            eye_width: 64,
            eye_height: 72,
            max_texture: 1024,
            fps: 30.0,
        },
        features: Features::NONE.with(Feature::Textures).with(Feature::ShadowedLight),
        counts: scene.counts(frames),
        bounds: Aabb {
            min: Vec3::ZERO,
            max: Vec3::ONE,
        },
    }
}

pub fn write_trace(meta: &Meta, scene: &Scene, frames: &[Frame], level: i32) -> (Vec<u8>, ContentHash) {
    let mut writer = TraceWriter::new(Vec::new(), level, meta, scene).expect("valid sample");
    for frame in frames {
        writer.write_frame(frame).expect("valid frame");
    }
    writer.finish().expect("finish")
}

pub fn sample_trace() -> Vec<u8> {
    let scene = sample_scene();
    let frames: Vec<Frame> = (0..3).map(sample_frame).collect();
    write_trace(&meta_for(&scene, 3), &scene, &frames, 3).0
}

/// Everything a trace holds, decoded.
#[derive(Debug, PartialEq)]
pub struct Decoded {
    pub meta: Meta,
    pub scene: Scene,
    pub frames: Vec<Frame>,
    pub hash: ContentHash,
}

/// Opens, decodes every chunk and verifies the hash: what a full reader does.
pub fn read_all(bytes: &[u8]) -> Result<Decoded> {
    let mut reader = TraceReader::open(Cursor::new(bytes))?;
    let hash = reader.verify()?;
    let scene = reader.scene()?;
    let frames = (0..reader.frame_count())
        .map(|i| reader.frame(i))
        .collect::<Result<Vec<_>>>()?;
    Ok(Decoded {
        meta: reader.meta().clone(),
        scene,
        frames,
        hash,
    })
}

/// A chunk as `(kind code, decompressed payload)`.
pub type RawChunk = (u32, Vec<u8>);

/// Assembles a file by hand from `(kind, raw payload)` pairs, with a correct content hash
/// computed as the format documents it.
pub fn assemble(major: u16, minor: u16, chunks: &[RawChunk]) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(b"STRC");
    out.extend_from_slice(&major.to_le_bytes());
    out.extend_from_slice(&minor.to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    let mut hasher = Sha256::new();
    for (kind, raw) in chunks {
        let packed = zstd::bulk::compress(raw, 3).expect("compress");
        out.extend_from_slice(&kind.to_le_bytes());
        out.extend_from_slice(&(raw.len() as u64).to_le_bytes());
        out.extend_from_slice(&(packed.len() as u64).to_le_bytes());
        out.extend_from_slice(&packed);
        hasher.update(kind.to_le_bytes());
        hasher.update((raw.len() as u64).to_le_bytes());
        hasher.update(raw);
    }
    out.extend_from_slice(&ChunkKind::End.code().to_le_bytes());
    out.extend_from_slice(&32u64.to_le_bytes());
    out.extend_from_slice(&32u64.to_le_bytes());
    out.extend_from_slice(&hasher.finalize());
    out
}

/// The decompressed chunks of a valid trace, in order, as `(kind code, raw)`.
pub fn raw_chunks(bytes: &[u8]) -> Vec<RawChunk> {
    let mut reader = TraceReader::open(Cursor::new(bytes)).expect("valid");
    let infos = reader.chunks().to_vec();
    infos
        .iter()
        .enumerate()
        .map(|(i, c)| (c.kind.code(), reader.raw_chunk(i).expect("raw")))
        .collect()
}
