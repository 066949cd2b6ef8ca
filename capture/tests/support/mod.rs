//! glTF fixtures generated on the fly (no downloads), written into a caller's directory.
//!
//! Shared with the CLI tests of the root package, which include this file by path, so it
//! uses only std, `serde_json` and `image`, and every writer takes a `&Path` directory and
//! returns the path of the main file.
#![allow(dead_code)]

use std::io::Cursor;
use std::path::{Path, PathBuf};

use serde_json::{json, Map, Value};

const FLOAT: u32 = 5126;
const UNSIGNED_SHORT: u32 = 5123;
const UNSIGNED_BYTE: u32 = 5121;
const CLAMP_TO_EDGE: u32 = 33071;
const MIRRORED_REPEAT: u32 = 33648;
const POINTS: u32 = 0;

/// The base-colour image of the textured fixtures: 8x4, every pixel different.
pub fn checker_image() -> image::RgbaImage {
    image::RgbaImage::from_fn(8, 4, |x, y| {
        image::Rgba([x as u8 * 32, y as u8 * 64, ((x + y) % 2) as u8 * 255, 255])
    })
}

/// Texture transform of the textured fixtures' base-colour texture.
pub const UV_OFFSET: [f32; 2] = [0.5, 0.25];
pub const UV_ROTATION: f32 = std::f32::consts::FRAC_PI_2;
pub const UV_SCALE: [f32; 2] = [2.0, 2.0];

/// Node translation of the textured quad.
pub const QUAD_TRANSLATION: [f32; 3] = [0.0, 0.5, -2.0];

/// Textured quad: external `quad.bin` and `checker.png`, KHR_texture_transform on the base
/// colour texture, one directional light and one perspective camera.
pub fn write_textured_gltf(dir: &Path) -> PathBuf {
    let mut bin = Bin::default();
    let mut doc = textured_scene(&mut bin, json!({ "name": "checker", "uri": "checker.png" }));
    std::fs::write(dir.join("checker.png"), png_bytes(&checker_image())).expect("write png");
    std::fs::write(dir.join("quad.bin"), &bin.bytes).expect("write bin");
    bin.finish(&mut doc, Some("quad.bin".to_string()));
    write_json(dir, "textured.gltf", &doc)
}

/// The same scene as [`write_textured_gltf`] in a GLB container, the image embedded
/// through a buffer view.
pub fn write_textured_glb(dir: &Path) -> PathBuf {
    let mut bin = Bin::default();
    let view = bin.view(&png_bytes(&checker_image()));
    let mut doc = textured_scene(
        &mut bin,
        json!({ "name": "checker", "bufferView": view, "mimeType": "image/png" }),
    );
    bin.finish(&mut doc, None);
    let path = dir.join("textured.glb");
    std::fs::write(&path, glb_bytes(&doc, &bin.bytes)).expect("write glb");
    path
}

/// A skinned strip of quads (two joints, the upper one rotating 90° about z over the
/// first second, like the glTF tutorial's SimpleSkin) and a rigidly animated triangle.
///
/// Nodes: 0 skinned mesh (its own translation (10, 0, 0) must be ignored), 1 root joint,
/// 2 upper joint at (0, 1, 0); 4 a static parent scaled by 2 holding 3, a triangle
/// translated from (3, 0, 0) at t = 0 to (5, 0, 0) at t = 2, whose children are 5 (the
/// same triangle at (0, 1, 0)) and 6 (a camera at (0, 0, 1)).
pub fn write_skinned_animated_gltf(dir: &Path) -> PathBuf {
    let mut bin = Bin::default();
    let mut positions = Vec::new();
    for row in 0..5 {
        let y = row as f32 * 0.5;
        positions.extend_from_slice(&[0.0, y, 0.0, 1.0, y, 0.0]);
    }
    let mut indices = Vec::new();
    for row in 0..4u16 {
        let (a, b, c, d) = (2 * row, 2 * row + 1, 2 * row + 3, 2 * row + 2);
        indices.extend_from_slice(&[a, b, c, a, c, d]);
    }
    let mut joints = Vec::new();
    let mut weights = Vec::new();
    for row in 0..5 {
        // Lower rows follow the root joint, upper rows the upper joint; the middle row
        // gets weights (1, 1), which the importer normalizes.
        let w: [f32; 4] = match row {
            0 | 1 => [1.0, 0.0, 0.0, 0.0],
            2 => [1.0, 1.0, 0.0, 0.0],
            _ => [0.0, 1.0, 0.0, 0.0],
        };
        for _ in 0..2 {
            joints.extend_from_slice(&[0u8, 1, 0, 0]);
            weights.extend_from_slice(&w);
        }
    }
    let strip_positions = bin.floats(&positions, "VEC3");
    let strip_indices = bin.u16s(&indices);
    let strip_joints = bin.u8s(&joints, "VEC4");
    let strip_weights = bin.floats(&weights, "VEC4");
    let inverse_bind = bin.floats(
        &[
            1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, //
            1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, -1.0, 0.0, 1.0,
        ],
        "MAT4",
    );
    let triangle = bin.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], "VEC3");
    let rotation_times = bin.floats(&[0.0, 1.0], "SCALAR");
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let rotations = bin.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, s, s], "VEC4");
    let translation_times = bin.floats(&[0.0, 2.0], "SCALAR");
    let translations = bin.floats(&[3.0, 0.0, 0.0, 5.0, 0.0, 0.0], "VEC3");
    let mut doc = json!({
        "scene": 0,
        "scenes": [{ "nodes": [0, 1, 4] }],
        "nodes": [
            { "name": "skinned", "mesh": 0, "skin": 0, "translation": [10.0, 0.0, 0.0] },
            { "name": "root_joint", "children": [2] },
            { "name": "upper_joint", "translation": [0.0, 1.0, 0.0] },
            { "name": "mover", "mesh": 1, "translation": [3.0, 0.0, 0.0], "children": [5, 6] },
            { "name": "scaled_parent", "scale": [2.0, 2.0, 2.0], "children": [3] },
            { "name": "rider", "mesh": 1, "translation": [0.0, 1.0, 0.0] },
            { "name": "follow_cam", "camera": 0, "translation": [0.0, 0.0, 1.0] }
        ],
        "meshes": [
            { "name": "Strip", "primitives": [{
                "attributes": {
                    "POSITION": strip_positions, "JOINTS_0": strip_joints, "WEIGHTS_0": strip_weights
                },
                "indices": strip_indices
            }] },
            { "name": "Tri", "primitives": [{ "attributes": { "POSITION": triangle } }] }
        ],
        "skins": [{ "joints": [1, 2], "inverseBindMatrices": inverse_bind }],
        "animations": [
            { "channels": [{ "sampler": 0, "target": { "node": 2, "path": "rotation" } }],
              "samplers": [{ "input": rotation_times, "output": rotations, "interpolation": "LINEAR" }] },
            { "channels": [{ "sampler": 0, "target": { "node": 3, "path": "translation" } }],
              "samplers": [{ "input": translation_times, "output": translations }] }
        ],
        "cameras": [{ "type": "perspective", "perspective": { "yfov": 1.0, "znear": 0.05 } }]
    });
    std::fs::write(dir.join("skinned.bin"), &bin.bytes).expect("write bin");
    bin.finish(&mut doc, Some("skinned.bin".to_string()));
    write_json(dir, "skinned.gltf", &doc)
}

/// One triangle in a file that lists `ext` in `extensionsUsed` and `extensionsRequired`.
pub fn write_gltf_with_required_extension(dir: &Path, ext: &str) -> PathBuf {
    let mut doc = triangle_document(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], None);
    doc["extensionsUsed"] = json!([ext]);
    doc["extensionsRequired"] = json!([ext]);
    write_json(dir, "required_extension.gltf", &doc)
}

/// One triangle in a file that lists `ext` in `extensionsUsed` only.
pub fn write_gltf_with_used_extension(dir: &Path, ext: &str) -> PathBuf {
    let mut doc = triangle_document(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], None);
    doc["extensionsUsed"] = json!([ext]);
    write_json(dir, "used_extension.gltf", &doc)
}

/// One triangle whose second vertex has a NaN x coordinate (buffer in a `data:` URI).
pub fn write_gltf_with_nan_position(dir: &Path) -> PathBuf {
    let doc = triangle_document(&[0.0, 0.0, 0.0, f32::NAN, 0.0, 0.0, 0.0, 1.0, 0.0], None);
    write_json(dir, "nan_position.gltf", &doc)
}

/// A triangle mesh instanced by `nodes` nodes side by side.
pub fn write_instanced_triangle(dir: &Path, nodes: usize) -> PathBuf {
    let mut doc = triangle_document(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], Some(&[0, 1, 2]));
    doc["scenes"] = json!([{ "nodes": (0..nodes).collect::<Vec<_>>() }]);
    doc["nodes"] = (0..nodes)
        .map(|n| json!({ "mesh": 0, "translation": [n as f32 * 2.0, 0.0, 0.0] }))
        .collect();
    write_json(dir, "instanced.gltf", &doc)
}

/// A triangle list whose `count` positions have no buffer view: all zeros, backed by no
/// bytes of the file, as the spec allows (sparse accessors use it).
pub fn write_gltf_with_implicit_positions(dir: &Path, count: u64) -> PathBuf {
    let doc = json!({
        "asset": { "version": "2.0" },
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0 } }] }],
        "accessors": [{ "componentType": 5126, "count": count, "type": "VEC3",
                        "min": [0.0, 0.0, 0.0], "max": [0.0, 0.0, 0.0] }]
    });
    write_json(dir, "implicit_positions.gltf", &doc)
}

/// One triangle with an index (7) beyond its three vertices.
pub fn write_gltf_with_bad_index(dir: &Path) -> PathBuf {
    let doc = triangle_document(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], Some(&[0, 1, 7]));
    write_json(dir, "bad_index.gltf", &doc)
}

/// One triangle whose buffer is the external file `missing.bin`, which is not written.
pub fn write_gltf_missing_bin(dir: &Path) -> PathBuf {
    let mut bin = Bin::default();
    let position = bin.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], "VEC3");
    let mut doc = json!({
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": position } }] }]
    });
    bin.finish(&mut doc, Some("missing.bin".to_string()));
    write_json(dir, "missing_bin.gltf", &doc)
}

/// A mesh named "Mixed" with a triangle primitive and a POINTS primitive.
pub fn write_gltf_with_points(dir: &Path) -> PathBuf {
    let mut bin = Bin::default();
    let position = bin.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], "VEC3");
    let mut doc = json!({
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "name": "Mixed", "primitives": [
            { "attributes": { "POSITION": position } },
            { "attributes": { "POSITION": position }, "mode": POINTS }
        ] }]
    });
    let uri = data_uri("application/octet-stream", &bin.bytes);
    bin.finish(&mut doc, Some(uri));
    write_json(dir, "points.gltf", &doc)
}

/// A textured triangle whose base-colour image is [`checker_image`] as lossless WebP,
/// named through `EXT_texture_webp` (required), in a `data:` URI.
pub fn write_gltf_with_webp_texture(dir: &Path) -> PathBuf {
    let mut doc = triangle_document(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], None);
    let mut webp = Vec::new();
    let image = checker_image();
    image::codecs::webp::WebPEncoder::new_lossless(&mut webp)
        .encode(&image, image.width(), image.height(), image::ExtendedColorType::Rgba8)
        .expect("encode webp");
    doc["meshes"][0]["primitives"][0]["material"] = json!(0);
    doc["materials"] = json!([{ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } }]);
    doc["textures"] = json!([{ "extensions": { "EXT_texture_webp": { "source": 0 } } }]);
    doc["images"] = json!([{ "uri": data_uri("image/webp", &webp) }]);
    doc["extensionsUsed"] = json!(["EXT_texture_webp"]);
    doc["extensionsRequired"] = json!(["EXT_texture_webp"]);
    write_json(dir, "webp_texture.gltf", &doc)
}

/// A textured triangle whose image is a BMP (by magic bytes), a format capture does not read.
pub fn write_gltf_with_bmp_texture(dir: &Path) -> PathBuf {
    let mut doc = triangle_document(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], None);
    let mut bmp = b"BM".to_vec();
    bmp.extend_from_slice(&[0; 60]);
    doc["meshes"][0]["primitives"][0]["material"] = json!(0);
    doc["materials"] = json!([{ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } }]);
    doc["textures"] = json!([{ "source": 0 }]);
    doc["images"] = json!([{ "uri": data_uri("image/bmp", &bmp) }]);
    write_json(dir, "bmp_texture.gltf", &doc)
}

/// One triangle stored as `KHR_mesh_quantization` allows (what gltfpack writes): unsigned
/// 16-bit positions (0, 0, 0), (2, 0, 0), (0, 2, 0) under a node scaled by 0.5, normalized
/// signed 8-bit normals (0, 0, 1) and normalized unsigned 16-bit UVs (0, 0), (1, 0), (0, 1)
/// of the checker texture.
pub fn write_quantized_gltf(dir: &Path) -> PathBuf {
    const SIGNED_BYTE: u32 = 5120;
    let mut bin = Bin::default();
    let positions: Vec<u8> = [0u16, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 0]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect(); // VEC3 padded to 8 bytes per element
    let position = bin.accessor(&positions, UNSIGNED_SHORT, 3, "VEC3");
    bin.views[bin.accessors[position]["bufferView"].as_u64().unwrap() as usize]["byteStride"] = json!(8);
    bin.accessors[position]["min"] = json!([0, 0, 0]);
    bin.accessors[position]["max"] = json!([2, 2, 0]);
    let normals: Vec<u8> = [0i8, 0, 127, 0, 0, 0, 127, 0, 0, 0, 127, 0]
        .iter()
        .map(|&v| v as u8)
        .collect();
    let normal = bin.accessor(&normals, SIGNED_BYTE, 3, "VEC3");
    bin.views[bin.accessors[normal]["bufferView"].as_u64().unwrap() as usize]["byteStride"] = json!(4);
    bin.accessors[normal]["normalized"] = json!(true);
    let uvs: Vec<u8> = [0u16, 0, 65535, 0, 0, 65535]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let uv = bin.accessor(&uvs, UNSIGNED_SHORT, 3, "VEC2");
    bin.accessors[uv]["normalized"] = json!(true);
    let mut doc = json!({
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0, "scale": [0.5, 0.5, 0.5] }],
        "meshes": [{ "primitives": [{
            "attributes": { "POSITION": position, "NORMAL": normal, "TEXCOORD_0": uv },
            "material": 0
        }] }],
        "materials": [{ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } }],
        "textures": [{ "source": 0 }],
        "images": [{ "uri": data_uri("image/png", &png_bytes(&checker_image())) }],
        "extensionsUsed": ["KHR_mesh_quantization"],
        "extensionsRequired": ["KHR_mesh_quantization"]
    });
    let uri = data_uri("application/octet-stream", &bin.bytes);
    bin.finish(&mut doc, Some(uri));
    write_json(dir, "quantized.gltf", &doc)
}

/// Which maps [`write_surface_maps_gltf`] gives its material.
#[derive(Clone, Copy, Debug, Default)]
pub struct MapsSpec {
    /// The normal map's (uniform) texel.
    pub normal: Option<[u8; 4]>,
    pub metallic_roughness: bool,
    pub occlusion: bool,
    pub emissive: bool,
    /// The occlusion map reads TEXCOORD_1 (which capture cannot use).
    pub occlusion_on_second_uv_set: bool,
}

/// The texels of the surface-map fixture's uniform 2x2 maps.
pub const METALLIC_ROUGHNESS_TEXEL: [u8; 4] = [0, 64, 255, 255];
pub const OCCLUSION_TEXEL: [u8; 4] = [64, 64, 64, 255];
pub const EMISSIVE_TEXEL: [u8; 4] = [255, 0, 0, 255];
pub const EMISSIVE_FACTOR: [f32; 3] = [1.0, 0.5, 1.0];
pub const EMISSIVE_STRENGTH: f32 = 2.0;

/// [`write_textured_gltf`]'s quad with the maps `spec` asks for, each a uniform 2x2 PNG in a
/// `data:` URI sampled with the base colour's texture transform (and `KHR_materials_emissive_strength`
/// on the emissive factor). Normal scale 0.5, occlusion strength 0.75.
pub fn write_surface_maps_gltf(dir: &Path, spec: MapsSpec) -> PathBuf {
    let mut bin = Bin::default();
    let mut doc = textured_scene(&mut bin, json!({ "name": "checker", "uri": "checker.png" }));
    std::fs::write(dir.join("checker.png"), png_bytes(&checker_image())).expect("write png");
    let transform = json!({ "KHR_texture_transform": {
        "offset": UV_OFFSET, "rotation": UV_ROTATION, "scale": UV_SCALE
    } });
    let add_map = |doc: &mut Value, texel: [u8; 4]| {
        let image = image::RgbaImage::from_pixel(2, 2, image::Rgba(texel));
        let images = doc["images"].as_array_mut().unwrap();
        images.push(json!({ "uri": data_uri("image/png", &png_bytes(&image)) }));
        let source = images.len() - 1;
        let textures = doc["textures"].as_array_mut().unwrap();
        textures.push(json!({ "source": source }));
        textures.len() - 1
    };
    let mut m = doc["materials"][0].clone();
    if let Some(texel) = spec.normal {
        let t = add_map(&mut doc, texel);
        m["normalTexture"] = json!({ "index": t, "scale": 0.5, "extensions": transform });
    }
    if spec.metallic_roughness {
        let t = add_map(&mut doc, METALLIC_ROUGHNESS_TEXEL);
        m["pbrMetallicRoughness"]["metallicRoughnessTexture"] = json!({ "index": t, "extensions": transform });
    }
    if spec.occlusion {
        let t = add_map(&mut doc, OCCLUSION_TEXEL);
        m["occlusionTexture"] = json!({ "index": t, "strength": 0.75, "extensions": transform });
        if spec.occlusion_on_second_uv_set {
            m["occlusionTexture"]["texCoord"] = json!(1);
        }
    }
    if spec.emissive {
        let t = add_map(&mut doc, EMISSIVE_TEXEL);
        m["emissiveTexture"] = json!({ "index": t, "extensions": transform });
        m["emissiveFactor"] = json!(EMISSIVE_FACTOR);
        m["extensions"] = json!({ "KHR_materials_emissive_strength": { "emissiveStrength": EMISSIVE_STRENGTH } });
    }
    // Opaque, so that every scheme can run on the fixture.
    m["alphaMode"] = json!("OPAQUE");
    doc["materials"][0] = m;
    doc["extensionsUsed"] = json!([
        "KHR_texture_transform",
        "KHR_lights_punctual",
        "KHR_materials_emissive_strength"
    ]);
    std::fs::write(dir.join("quad.bin"), &bin.bytes).expect("write bin");
    bin.finish(&mut doc, Some("quad.bin".to_string()));
    write_json(dir, "surface_maps.gltf", &doc)
}

/// Vertices per side of [`write_wavy_grid_glb`]'s grid.
pub const GRID_SIDE: u16 = 17;

/// A wavy 2 m x 2 m grid of 512 triangles (17 x 17 vertices, smooth normals, UVs over
/// [0, 1]², the checker texture) in a GLB: the source the compressed fixtures in
/// `capture/tests/fixtures/` were made from (`scripts/make-compressed-fixtures.sh`).
pub fn write_wavy_grid_glb(dir: &Path) -> PathBuf {
    let n = usize::from(GRID_SIDE);
    let (mut positions, mut normals, mut uvs) = (Vec::new(), Vec::new(), Vec::new());
    for j in 0..n {
        for i in 0..n {
            let (u, v) = (i as f32 / (n - 1) as f32, j as f32 / (n - 1) as f32);
            let (x, z) = (2.0 * u - 1.0, 2.0 * v - 1.0);
            let (kx, kz) = (2.0, 3.0);
            let y = 0.1 * (kx * x).sin() * (kz * z).cos();
            let (dx, dz) = (
                0.1 * kx * (kx * x).cos() * (kz * z).cos(),
                -0.1 * kz * (kx * x).sin() * (kz * z).sin(),
            );
            let len = (dx * dx + 1.0 + dz * dz).sqrt();
            positions.extend_from_slice(&[x, y, z]);
            normals.extend_from_slice(&[-dx / len, 1.0 / len, -dz / len]);
            uvs.extend_from_slice(&[u, v]);
        }
    }
    let mut indices = Vec::new();
    for j in 0..GRID_SIDE - 1 {
        for i in 0..GRID_SIDE - 1 {
            let a = j * GRID_SIDE + i;
            let (b, c, d) = (a + 1, a + GRID_SIDE + 1, a + GRID_SIDE);
            indices.extend_from_slice(&[a, d, c, a, c, b]);
        }
    }
    let mut bin = Bin::default();
    let position = bin.floats(&positions, "VEC3");
    let normal = bin.floats(&normals, "VEC3");
    let uv = bin.floats(&uvs, "VEC2");
    let index = bin.u16s(&indices);
    let image = bin.view(&png_bytes(&checker_image()));
    let mut doc = json!({
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "name": "grid", "mesh": 0 }],
        "meshes": [{ "name": "Grid", "primitives": [{
            "attributes": { "POSITION": position, "NORMAL": normal, "TEXCOORD_0": uv },
            "indices": index,
            "material": 0
        }] }],
        "materials": [{ "name": "checker", "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } }],
        "textures": [{ "source": 0 }],
        "images": [{ "name": "checker", "bufferView": image, "mimeType": "image/png" }]
    });
    bin.finish(&mut doc, None);
    let path = dir.join("wavy_grid.glb");
    std::fs::write(&path, glb_bytes(&doc, &bin.bytes)).expect("write glb");
    path
}

/// The 36 bytes of [`write_gltf_with_buffer_uri`]'s triangle (three `VEC3` floats).
pub fn triangle_buffer() -> Vec<u8> {
    [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        .iter()
        .flat_map(|f| f.to_le_bytes())
        .collect()
}

/// One triangle whose 36-byte buffer is read from `uri` (which the caller provides, or
/// not: `/etc/passwd`, `../x.bin`, a FIFO...).
pub fn write_gltf_with_buffer_uri(dir: &Path, uri: &str) -> PathBuf {
    let mut doc = triangle_document(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], None);
    doc["buffers"][0]["uri"] = json!(uri);
    write_json(dir, "buffer_uri.gltf", &doc)
}

/// A textured triangle whose base-colour image is the file at `uri`.
pub fn write_gltf_with_image_uri(dir: &Path, uri: &str) -> PathBuf {
    let mut doc = triangle_document(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], None);
    doc["meshes"][0]["primitives"][0]["material"] = json!(0);
    doc["materials"] = json!([{ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } }]);
    doc["textures"] = json!([{ "source": 0 }]);
    doc["images"] = json!([{ "uri": uri }]);
    write_json(dir, "image_uri.gltf", &doc)
}

/// One triangle under a node translated by `translation`.
pub fn write_gltf_with_translation(dir: &Path, translation: [f32; 3]) -> PathBuf {
    let mut doc = triangle_document(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], None);
    doc["nodes"][0]["translation"] = json!(translation);
    write_json(dir, "translated.gltf", &doc)
}

/// Binary buffer under construction, with the buffer views and accessors describing it.
#[derive(Default)]
struct Bin {
    bytes: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Bin {
    /// Appends `data` (4-byte aligned) as a new buffer view; returns its index.
    fn view(&mut self, data: &[u8]) -> usize {
        while self.bytes.len() % 4 != 0 {
            self.bytes.push(0);
        }
        let offset = self.bytes.len();
        self.bytes.extend_from_slice(data);
        self.views
            .push(json!({ "buffer": 0, "byteOffset": offset, "byteLength": data.len() }));
        self.views.len() - 1
    }

    fn accessor(&mut self, data: &[u8], component_type: u32, count: usize, ty: &str) -> usize {
        let view = self.view(data);
        self.accessors.push(json!({
            "bufferView": view, "componentType": component_type, "count": count, "type": ty
        }));
        self.accessors.len() - 1
    }

    /// A float accessor, with `min`/`max` when the values are finite (as POSITION needs).
    fn floats(&mut self, values: &[f32], ty: &str) -> usize {
        let width = match ty {
            "SCALAR" => 1,
            "VEC2" => 2,
            "VEC3" => 3,
            "VEC4" => 4,
            "MAT4" => 16,
            other => panic!("fixture accessor type {other}"),
        };
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let index = self.accessor(&bytes, FLOAT, values.len() / width, ty);
        if values.iter().all(|v| v.is_finite()) {
            let column = |c: usize| values.iter().skip(c).step_by(width).copied();
            let min: Vec<f32> = (0..width).map(|c| column(c).fold(f32::INFINITY, f32::min)).collect();
            let max: Vec<f32> = (0..width)
                .map(|c| column(c).fold(f32::NEG_INFINITY, f32::max))
                .collect();
            self.accessors[index]["min"] = json!(min);
            self.accessors[index]["max"] = json!(max);
        }
        index
    }

    fn u16s(&mut self, values: &[u16]) -> usize {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        self.accessor(&bytes, UNSIGNED_SHORT, values.len(), "SCALAR")
    }

    fn u8s(&mut self, values: &[u8], ty: &str) -> usize {
        let width = if ty == "VEC4" { 4 } else { 1 };
        self.accessor(values, UNSIGNED_BYTE, values.len() / width, ty)
    }

    /// Adds the asset header, the buffer (at `uri`, or the GLB BIN chunk when `None`),
    /// its views and accessors to `doc`.
    fn finish(&self, doc: &mut Value, uri: Option<String>) {
        let mut buffer = Map::new();
        buffer.insert("byteLength".into(), json!(self.bytes.len()));
        if let Some(uri) = uri {
            buffer.insert("uri".into(), json!(uri));
        }
        doc["asset"] = json!({ "version": "2.0", "generator": "shadetrace test fixtures" });
        doc["buffers"] = json!([buffer]);
        doc["bufferViews"] = json!(self.views);
        doc["accessors"] = json!(self.accessors);
    }
}

/// The textured scene shared by the `.gltf` and `.glb` fixtures, with `image` as its only
/// image.
fn textured_scene(bin: &mut Bin, image: Value) -> Value {
    let position = bin.floats(
        &[-1.0, -1.0, 0.0, 1.0, -1.0, 0.0, 1.0, 1.0, 0.0, -1.0, 1.0, 0.0],
        "VEC3",
    );
    let normal = bin.floats(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0], "VEC3");
    let uv = bin.floats(&[0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0], "VEC2");
    let indices = bin.u16s(&[0, 1, 2, 0, 2, 3]);
    let s = std::f32::consts::FRAC_1_SQRT_2;
    json!({
        "scene": 0,
        "scenes": [{ "nodes": [0, 1, 2] }],
        "nodes": [
            { "name": "quad", "mesh": 0, "translation": QUAD_TRANSLATION },
            // Rotated -90 degrees about x: the light shines down -y.
            { "name": "sun", "rotation": [-s, 0.0, 0.0, s],
              "extensions": { "KHR_lights_punctual": { "light": 0 } } },
            { "name": "eye", "camera": 0, "translation": [0.0, 1.0, 5.0] }
        ],
        "meshes": [{ "name": "Quad", "primitives": [{
            "attributes": { "POSITION": position, "NORMAL": normal, "TEXCOORD_0": uv },
            "indices": indices,
            "material": 0
        }] }],
        "materials": [{
            "name": "checker",
            "pbrMetallicRoughness": {
                "baseColorFactor": [1.0, 0.5, 0.25, 1.0],
                "baseColorTexture": { "index": 0, "extensions": { "KHR_texture_transform": {
                    "offset": UV_OFFSET, "rotation": UV_ROTATION, "scale": UV_SCALE
                } } },
                "metallicFactor": 0.0,
                "roughnessFactor": 0.5
            },
            "alphaMode": "MASK",
            "alphaCutoff": 0.3,
            "doubleSided": true
        }],
        "textures": [{ "source": 0, "sampler": 0 }],
        "samplers": [{ "wrapS": CLAMP_TO_EDGE, "wrapT": MIRRORED_REPEAT }],
        "images": [image],
        "cameras": [{ "name": "main", "type": "perspective",
                      "perspective": { "yfov": 0.8, "znear": 0.1, "zfar": 100.0 } }],
        "extensionsUsed": ["KHR_texture_transform", "KHR_lights_punctual"],
        "extensions": { "KHR_lights_punctual": { "lights": [
            { "name": "sun", "type": "directional", "color": [1.0, 0.9, 0.8], "intensity": 3.0 }
        ] } }
    })
}

/// A one-triangle document with its buffer in a `data:` URI.
fn triangle_document(positions: &[f32], indices: Option<&[u16]>) -> Value {
    let mut bin = Bin::default();
    let position = bin.floats(positions, "VEC3");
    let mut primitive = json!({ "attributes": { "POSITION": position } });
    if let Some(indices) = indices {
        primitive["indices"] = json!(bin.u16s(indices));
    }
    let mut doc = json!({
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "name": "Triangle", "primitives": [primitive] }]
    });
    let uri = data_uri("application/octet-stream", &bin.bytes);
    bin.finish(&mut doc, Some(uri));
    doc
}

fn write_json(dir: &Path, name: &str, doc: &Value) -> PathBuf {
    let path = dir.join(name);
    let text = serde_json::to_string_pretty(doc).expect("serialize fixture");
    std::fs::write(&path, text).expect("write gltf");
    path
}

fn png_bytes(image: &image::RgbaImage) -> Vec<u8> {
    let mut bytes = Vec::new();
    image
        .write_to(&mut Cursor::new(&mut bytes), image::ImageFormat::Png)
        .expect("encode png");
    bytes
}

/// A GLB container: header, JSON chunk (space-padded), BIN chunk (zero-padded).
fn glb_bytes(doc: &Value, bin: &[u8]) -> Vec<u8> {
    let mut json = serde_json::to_vec(doc).expect("serialize fixture");
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let mut bin = bin.to_vec();
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

fn data_uri(media_type: &str, bytes: &[u8]) -> String {
    format!("data:{media_type};base64,{}", base64(bytes))
}

fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [chunk[0], *chunk.get(1).unwrap_or(&0), *chunk.get(2).unwrap_or(&0)];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ALPHABET[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}
