//! glTF import against generated fixtures (see `support`).

mod support;

use std::path::Path;

use glam::{Mat4, Vec2, Vec3};
use sha2::{Digest, Sha256};
use shadetrace_capture::gltf_import::{load_gltf, ImportLimits, ImportOptions};
use shadetrace_capture::source::SourceScene;
use shadetrace_capture::Error;
use shadetrace_formats::{AlphaMode, LightKind, Motion, Source, Wrap};

const OPTS: ImportOptions = ImportOptions {
    max_texture: 4096,
    limits: ImportLimits::DEFAULT,
};

fn load(path: &Path) -> SourceScene {
    load_gltf(path, &OPTS).unwrap_or_else(|e| panic!("{e}"))
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-5
}

#[test]
fn textured_gltf_imports_geometry_material_texture_light_and_camera() {
    let dir = tempfile::tempdir().unwrap();
    let path = support::write_textured_gltf(dir.path());
    let scene = load(&path);

    assert_eq!(scene.name, "textured");
    let Source::File { file_name, sha256 } = &scene.source else {
        panic!("not a file source");
    };
    assert_eq!(file_name, "textured.gltf");
    let digest: [u8; 32] = Sha256::digest(std::fs::read(&path).unwrap()).into();
    assert_eq!(*sha256, digest);
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);

    let meshes = &scene.scene.geometry.meshes;
    assert_eq!(meshes.len(), 1);
    let quad = &meshes[0];
    assert_eq!(quad.name, "Quad");
    assert_eq!(quad.motion, Motion::Static);
    assert_eq!(quad.indices, [0, 1, 2, 0, 2, 3]);
    let offset = Vec3::from_array(support::QUAD_TRANSLATION);
    assert!(close(quad.positions[0], Vec3::new(-1.0, -1.0, 0.0) + offset));
    assert!(quad.normals.iter().all(|&n| close(n, Vec3::Z)));
    // Vertex 2 has uv (1, 0): scale (2, 2), rotate a quarter turn, offset (0.5, 0.25).
    assert!((quad.uvs[2] - Vec2::new(0.5, -1.75)).length() < 1e-5, "{}", quad.uvs[2]);
    assert!(!quad.uv_atlas_unique && quad.patch_ids.is_empty());

    let material = &scene.scene.materials[quad.material as usize];
    assert_eq!(material.base_color, [1.0, 0.5, 0.25, 1.0]);
    assert_eq!(material.base_color_texture, Some(0));
    assert_eq!(material.alpha, AlphaMode::Mask { cutoff: 0.3 });
    assert!(material.double_sided);
    assert_eq!((material.specular_exponent, material.specular_strength), (7.5, 0.04));

    let texture = &scene.scene.textures[0];
    let expected = support::checker_image();
    assert_eq!((texture.width, texture.height), expected.dimensions());
    assert_eq!(texture.rgba8, expected.into_raw());
    assert_eq!(
        (texture.wrap_u, texture.wrap_v),
        (Wrap::ClampToEdge, Wrap::MirroredRepeat)
    );
    assert_eq!(texture.name, "checker");

    assert_eq!(scene.scene.lights.len(), 1);
    let sun = &scene.scene.lights[0];
    assert!(sun.shadowed);
    assert_eq!(sun.intensity, 3.0);
    let LightKind::Directional { direction } = sun.kind else {
        panic!("not directional: {:?}", sun.kind);
    };
    assert!(close(direction, Vec3::NEG_Y), "{direction}");

    assert_eq!(scene.cameras.len(), 1);
    assert_eq!(scene.cameras[0].name, "main");
    assert_eq!(
        (scene.cameras[0].yfov, scene.cameras[0].znear, scene.cameras[0].zfar),
        (0.8, 0.1, Some(100.0))
    );
    let pose = scene.motion.camera_pose(0, 0.0);
    assert!(close(pose.position, Vec3::new(0.0, 1.0, 5.0)));
    assert_eq!(scene.animation_duration_s, 0.0);
    let frame = scene.motion.sample(0.0);
    assert!(frame.rigid_transforms.is_empty() && frame.skinned.is_empty());
}

#[test]
fn glb_imports_the_same_scene_as_gltf() {
    let dir = tempfile::tempdir().unwrap();
    let gltf = load(&support::write_textured_gltf(dir.path()));
    let glb = load(&support::write_textured_glb(dir.path()));
    assert_eq!(glb.name, "textured");
    assert_eq!(glb.scene, gltf.scene);
    assert_eq!(glb.cameras, gltf.cameras);
    assert!(glb.warnings.is_empty(), "{:?}", glb.warnings);
}

#[test]
fn max_texture_scales_textures_down_keeping_aspect() {
    let dir = tempfile::tempdir().unwrap();
    let path = support::write_textured_gltf(dir.path());
    let scene = load_gltf(&path, &ImportOptions { max_texture: 4, ..OPTS }).unwrap();
    let texture = &scene.scene.textures[0];
    assert_eq!((texture.width, texture.height), (4, 2));
    assert_eq!(texture.rgba8.len(), 4 * 2 * 4);
}

#[test]
fn skinned_mesh_follows_its_joints() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load(&support::write_skinned_animated_gltf(dir.path()));
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    assert_eq!(scene.animation_duration_s, 2.0);
    let strip = &scene.scene.geometry.meshes[0];
    assert_eq!(strip.motion, Motion::Skinned { slot: 0 });
    assert_eq!(strip.positions.len(), 10);
    assert_eq!(strip.triangle_count(), 8);
    assert!(strip.normals.iter().all(|&n| close(n, Vec3::Z)), "generated normals");
    assert!(strip.uvs.is_empty(), "no texture, no uvs");
    let material = &scene.scene.materials[strip.material as usize];
    assert_eq!(material.base_color, [1.0; 4], "glTF default material");

    // At t = 0 the joints are at their bind pose, so skinning gives the bind positions
    // (the skinned node's own translation does not apply).
    let rest = scene.motion.sample(0.0);
    assert_eq!(rest.skinned.len(), 1);
    for (posed, bind) in rest.skinned[0].positions.iter().zip(&strip.positions) {
        assert!(close(*posed, *bind), "{posed} vs {bind}");
    }

    // At t = 1 the upper joint has turned 90 degrees about z around (0, 1, 0).
    let turned = scene.motion.sample(1.0);
    let skinned = &turned.skinned[0];
    assert!(
        close(skinned.positions[8], Vec3::new(-1.0, 1.0, 0.0)),
        "{}",
        skinned.positions[8]
    );
    assert!(close(skinned.positions[9], Vec3::new(-1.0, 2.0, 0.0)));
    // The middle row is weighted half and half.
    assert!(
        close(skinned.positions[5], Vec3::new(0.5, 1.5, 0.0)),
        "{}",
        skinned.positions[5]
    );
    assert!(close(skinned.positions[0], Vec3::ZERO));
    assert!(skinned.normals.iter().all(|&n| close(n, Vec3::Z)));
    assert_ne!(rest.skinned[0].positions, skinned.positions);
    assert_eq!(scene.motion.sample(0.5), scene.motion.sample(0.5), "deterministic");
}

#[test]
fn rigid_nodes_and_their_children_get_slots_that_move() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load(&support::write_skinned_animated_gltf(dir.path()));
    let meshes = &scene.scene.geometry.meshes;
    assert_eq!(meshes.len(), 3);
    assert_eq!(meshes[1].motion, Motion::Rigid { slot: 0 });
    assert_eq!(meshes[2].motion, Motion::Rigid { slot: 1 });
    assert_eq!(meshes[1].positions, [Vec3::ZERO, Vec3::X, Vec3::Y], "mesh space");
    assert!(meshes[1].normals.iter().all(|&n| close(n, Vec3::Z)));

    let translation = |m: Mat4| m.w_axis.truncate();
    let start = scene.motion.sample(0.0);
    let later = scene.motion.sample(1.0);
    assert_eq!(start.rigid_transforms.len(), 2);
    // Parent scale 2 times the animated translation (3 -> 5 over two seconds).
    assert!(close(translation(start.rigid_transforms[0]), Vec3::new(6.0, 0.0, 0.0)));
    assert!(close(translation(later.rigid_transforms[0]), Vec3::new(8.0, 0.0, 0.0)));
    assert!(close(translation(later.rigid_transforms[1]), Vec3::new(8.0, 2.0, 0.0)));
    assert!(close(
        translation(scene.motion.sample(5.0).rigid_transforms[0]),
        Vec3::new(10.0, 0.0, 0.0)
    ));

    assert_eq!(scene.cameras.len(), 1);
    assert_eq!(scene.cameras[0].name, "follow_cam");
    assert_eq!(scene.cameras[0].zfar, None);
    let pose = scene.motion.camera_pose(0, 1.0);
    assert!(close(pose.position, Vec3::new(8.0, 0.0, 2.0)), "{}", pose.position);
    assert!(pose.orientation.abs_diff_eq(glam::Quat::IDENTITY, 1e-6));
}

fn error_of(path: &Path) -> Error {
    match load_gltf(path, &OPTS) {
        Ok(_) => panic!("{} loaded", path.display()),
        Err(e) => e,
    }
}

fn assert_one_line_naming_file(e: &Error, path: &Path) {
    let msg = e.to_string();
    assert!(!msg.contains('\n'), "{msg}");
    assert!(msg.contains(&path.display().to_string()), "{msg}");
}

#[test]
fn required_unsupported_extensions_are_rejected_by_name() {
    let dir = tempfile::tempdir().unwrap();
    for ext in [
        "EXT_mesh_gpu_instancing",
        "KHR_materials_pbrSpecularGlossiness",
        "KHR_mesh_fancy_future",
    ] {
        let path = support::write_gltf_with_required_extension(dir.path(), ext);
        let e = error_of(&path);
        assert!(matches!(e, Error::Unsupported { .. }), "{e:?}");
        assert!(e.to_string().contains(ext), "{e}");
        assert_one_line_naming_file(&e, &path);
    }
    // Required extensions the importer implements are fine.
    for ext in [
        "KHR_texture_transform",
        "KHR_mesh_quantization",
        "EXT_texture_webp",
        "KHR_draco_mesh_compression",
        "EXT_meshopt_compression",
        "KHR_meshopt_compression",
        "KHR_texture_basisu",
    ] {
        let path = support::write_gltf_with_required_extension(dir.path(), ext);
        assert_eq!(load(&path).scene.geometry.meshes.len(), 1, "{ext}");
    }
}

#[test]
fn used_but_not_required_extensions_only_warn() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load(&support::write_gltf_with_used_extension(
        dir.path(),
        "KHR_materials_clearcoat",
    ));
    assert_eq!(scene.scene.geometry.meshes.len(), 1);
    assert_eq!(scene.warnings.len(), 1);
    assert!(
        scene.warnings[0].contains("KHR_materials_clearcoat"),
        "{:?}",
        scene.warnings
    );
}

#[test]
fn non_finite_positions_are_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let path = support::write_gltf_with_nan_position(dir.path());
    let e = error_of(&path);
    assert!(matches!(e, Error::Input { .. }), "{e:?}");
    assert!(
        e.to_string()
            .contains("non-finite vertex position in mesh 0 (Triangle)"),
        "{e}"
    );
    assert_one_line_naming_file(&e, &path);
}

fn with_geometry_bytes(geometry_bytes: u64) -> ImportOptions {
    ImportOptions {
        limits: ImportLimits {
            geometry_bytes,
            ..ImportLimits::DEFAULT
        },
        ..OPTS
    }
}

/// A few bytes of JSON declaring gigabytes of zeros are refused before anything is
/// allocated, naming the accessor.
#[test]
fn accessors_without_buffer_views_are_charged_to_the_budget() {
    let dir = tempfile::tempdir().unwrap();
    let path = support::write_gltf_with_implicit_positions(dir.path(), 1 << 40);
    let e = error_of(&path);
    assert!(
        e.to_string().contains("POSITION of mesh 0 primitive 0 (accessor 0)"),
        "{e}"
    );
    assert!(e.to_string().contains("bytes of geometry"), "{e}");
    assert_one_line_naming_file(&e, &path);
    // Within the budget they are read: 3 zero positions, one degenerate triangle.
    let small = support::write_gltf_with_implicit_positions(dir.path(), 3);
    assert!(load_gltf(&small, &with_geometry_bytes(36)).is_ok());
    assert!(load_gltf(&small, &with_geometry_bytes(35)).is_err());
}

/// Every node that instances a mesh reads its accessors again, and pays for them again:
/// the budget bounds the flattened scene, not just the file's data.
#[test]
fn each_mesh_instance_is_charged_to_the_budget() {
    let dir = tempfile::tempdir().unwrap();
    let one = 3 * 12 + 3 * 4; // three VEC3 f32 positions and three indices as u32
    let path = support::write_instanced_triangle(dir.path(), 10);
    let scene = load_gltf(&path, &with_geometry_bytes(10 * one)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.scene.geometry.meshes.len(), 10);
    let e = load_gltf(&path, &with_geometry_bytes(10 * one - 1))
        .err()
        .expect("refused");
    assert!(e.to_string().contains("mesh instances count again"), "{e}");
    assert_one_line_naming_file(&e, &path);
}

#[test]
fn out_of_range_indices_are_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let path = support::write_gltf_with_bad_index(dir.path());
    let e = error_of(&path);
    assert!(e.to_string().contains("index 7 out of range (3 vertices)"), "{e}");
    assert_one_line_naming_file(&e, &path);
}

#[test]
fn missing_buffer_file_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let path = support::write_gltf_missing_bin(dir.path());
    let e = error_of(&path);
    assert!(matches!(e, Error::Input { .. }), "{e:?}");
    assert!(e.to_string().contains("missing.bin"), "{e}");
    assert_one_line_naming_file(&e, &path);
}

#[test]
fn missing_image_file_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let path = support::write_textured_gltf(dir.path());
    std::fs::remove_file(dir.path().join("checker.png")).unwrap();
    let e = error_of(&path);
    assert!(e.to_string().contains("checker.png"), "{e}");
    assert_one_line_naming_file(&e, &path);
}

#[test]
fn images_in_other_formats_are_unsupported() {
    let dir = tempfile::tempdir().unwrap();
    let path = support::write_gltf_with_bmp_texture(dir.path());
    let e = error_of(&path);
    assert!(matches!(e, Error::Unsupported { .. }), "{e:?}");
    let msg = e.to_string();
    assert!(msg.contains("image format") && msg.contains("texture 0"), "{msg}");
}

#[test]
fn webp_textures_named_by_ext_texture_webp_decode() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load(&support::write_gltf_with_webp_texture(dir.path()));
    let texture = &scene.scene.textures[0];
    assert_eq!((texture.width, texture.height), (8, 4));
    assert_eq!(
        texture.rgba8,
        support::checker_image().into_raw(),
        "lossless WebP round trip"
    );
}

#[test]
fn points_primitives_are_skipped_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let path = support::write_gltf_with_points(dir.path());
    let scene = load(&path);
    assert_eq!(scene.scene.geometry.meshes.len(), 1);
    assert_eq!(scene.scene.geometry.meshes[0].name, "Mixed/0");
    assert_eq!(scene.warnings.len(), 1, "{:?}", scene.warnings);
    let warning = &scene.warnings[0];
    assert!(warning.contains("POINTS") && warning.contains("Mixed"), "{warning}");
    assert!(warning.starts_with(&path.display().to_string()), "{warning}");
    // Flat normals for the non-indexed triangle.
    assert!(scene.scene.geometry.meshes[0]
        .normals
        .iter()
        .all(|&n| close(n, Vec3::Z)));
}

#[test]
fn garbage_and_truncated_files_are_errors_not_panics() {
    let dir = tempfile::tempdir().unwrap();
    let glb = std::fs::read(support::write_textured_glb(dir.path())).unwrap();
    for len in [0, 3, 11, 12, 20, 100, glb.len() - 1] {
        let path = dir.path().join(format!("cut{len}.glb"));
        std::fs::write(&path, &glb[..len]).unwrap();
        let e = error_of(&path);
        assert_one_line_naming_file(&e, &path);
    }
    let path = dir.path().join("garbage.gltf");
    std::fs::write(
        &path,
        "{ \"asset\": { \"version\": \"2.0\" }, \"nodes\": [ { \"children\": [0] } ] ",
    )
    .unwrap();
    assert_one_line_naming_file(&error_of(&path), &path);
    let path = dir.path().join("cycle.gltf");
    std::fs::write(
        &path,
        r#"{ "asset": { "version": "2.0" }, "scenes": [ { "nodes": [0] } ],
             "nodes": [ { "children": [1] }, { "children": [0] } ] }"#,
    )
    .unwrap();
    assert_one_line_naming_file(&error_of(&path), &path);
}

#[test]
fn quantized_attributes_decode_as_khr_mesh_quantization_says() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load(&support::write_quantized_gltf(dir.path()));
    let mesh = &scene.scene.geometry.meshes[0];
    let expected = [Vec3::ZERO, Vec3::X, Vec3::Y];
    for (p, e) in mesh.positions.iter().zip(expected) {
        assert!(close(*p, e), "{p} != {e}");
    }
    assert!(mesh.normals.iter().all(|n| close(*n, Vec3::Z)), "{:?}", mesh.normals);
    let uvs: Vec<[f32; 2]> = mesh.uvs.iter().map(|t| t.to_array()).collect();
    assert_eq!(uvs, [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]);
}

/// Every map the fixture has ends up in the trace's surface maps: data textures marked
/// linear, the emissive factor times its strength, MikkTSpace tangents (unit, in the quad's
/// plane) on the mesh, and no "ignored" warning.
#[test]
fn surface_maps_are_captured_with_tangents() {
    let dir = tempfile::tempdir().unwrap();
    let spec = support::MapsSpec {
        normal: Some([200, 128, 200, 255]),
        metallic_roughness: true,
        occlusion: true,
        emissive: true,
        ..Default::default()
    };
    let scene = load(&support::write_surface_maps_gltf(dir.path(), spec));
    assert!(
        scene.warnings.iter().all(|w| !w.contains("ignored")),
        "{:?}",
        scene.warnings
    );
    let maps = &scene.scene.surface_maps;
    let m = maps.of(scene.scene.geometry.meshes[0].material);
    let (normal, mr, occlusion, emissive) = (
        m.normal.unwrap(),
        m.metallic_roughness.unwrap(),
        m.occlusion.unwrap(),
        m.emissive_texture.unwrap(),
    );
    assert_eq!((normal.1, occlusion.1), (0.5, 0.75));
    assert_eq!((mr.1, mr.2), (0.5, 0.0), "the fixture's roughness and metallic factors");
    let expected = support::EMISSIVE_FACTOR.map(|c| c * support::EMISSIVE_STRENGTH);
    assert_eq!(m.emissive, expected);
    let texel = |t: u32| scene.scene.textures[t as usize].rgba8[..4].to_vec();
    assert_eq!(texel(occlusion.0), support::OCCLUSION_TEXEL);
    assert_eq!(texel(emissive), support::EMISSIVE_TEXEL);
    let mut linear = maps.linear_textures.clone();
    linear.sort();
    let mut data = vec![normal.0, mr.0, occlusion.0];
    data.sort();
    assert_eq!(linear, data, "normal, metallic-roughness and occlusion maps hold data");
    let mesh = &scene.scene.geometry.meshes[0];
    let tangents = &maps.tangents[0];
    assert_eq!(tangents.len(), mesh.positions.len());
    for (t, n) in tangents.iter().zip(&mesh.normals) {
        assert!(
            (t.truncate().length() - 1.0).abs() < 1e-5 && t.truncate().dot(*n).abs() < 1e-5,
            "{t}"
        );
        assert!(t.z.abs() < 1e-5, "in the quad's plane: {t}");
    }
}

/// A map on another UV set than base colour is dropped with a warning naming it; the
/// others stay.
#[test]
fn a_map_on_another_uv_set_is_named_and_dropped() {
    let dir = tempfile::tempdir().unwrap();
    let spec = support::MapsSpec {
        occlusion: true,
        occlusion_on_second_uv_set: true,
        emissive: true,
        ..Default::default()
    };
    let scene = load(&support::write_surface_maps_gltf(dir.path(), spec));
    let m = scene.scene.surface_maps.of(0);
    assert!(m.occlusion.is_none() && m.emissive_texture.is_some());
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("occlusion") && w.contains("TEXCOORD_1")),
        "{:?}",
        scene.warnings
    );
}
