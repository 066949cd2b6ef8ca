//! The built-in scenes: deterministic, each with the properties it exists to stress.

use std::collections::BTreeMap;

use glam::{Vec3, Vec4Swizzles};
use shadetrace_capture::procedural::{BUILTIN_SCENES, SPHERE_LEVELS};
use shadetrace_capture::{capture, CaptureOptions, Captured, Input};
use shadetrace_formats::{Eye, Feature, LightKind, Motion};

fn capture_builtin(spec: &str, frames: u32) -> Captured {
    let opts = CaptureOptions {
        frames,
        ..CaptureOptions::default()
    };
    capture(&Input::Builtin(spec.into()), &opts, &mut |_, _| {}).unwrap()
}

#[test]
fn every_builtin_is_deterministic_and_level_independent() {
    for (name, _) in BUILTIN_SCENES {
        let a = capture_builtin(name, 2);
        let b = capture_builtin(name, 2);
        assert_eq!(a, b, "{name} differs between two captures");
        let (bytes_fast, hash_fast) = a.write(Vec::new(), 1).unwrap();
        let (bytes_small, hash_small) = b.write(Vec::new(), 15).unwrap();
        assert_eq!(hash_fast, hash_small, "{name}: zstd level changed the hash");
        assert!(bytes_small.len() <= bytes_fast.len());
    }
}

#[test]
fn features_are_what_each_scene_requires() {
    let features = |name: &str| capture_builtin(name, 1).meta.features;
    let floor = features("floor");
    assert!(floor.contains(Feature::Textures) && floor.contains(Feature::ShadowedLight));
    assert!(!floor.contains(Feature::PatchIds) && !floor.contains(Feature::ExtraLights));
    let spheres = features("spheres");
    assert!(spheres.contains(Feature::PatchIds) && spheres.contains(Feature::UniqueUvAtlas));
    let hairball = features("hairball");
    assert!(
        !hairball.contains(Feature::Textures),
        "untextured scene flagged textured"
    );
    let room = features("light-room");
    assert!(room.contains(Feature::ExtraLights) && !room.contains(Feature::ShadowedLight));
    for name in ["floor", "spheres", "hairball", "depth-stack", "light-room"] {
        let f = features(name);
        assert!(
            !f.contains(Feature::Animation) && !f.contains(Feature::Skinning),
            "{name}"
        );
    }
}

#[test]
fn untextured_meshes_carry_no_uvs() {
    for (name, _) in BUILTIN_SCENES {
        let c = capture_builtin(name, 1);
        for mesh in &c.scene.geometry.meshes {
            let textured = c.scene.materials[mesh.material as usize].base_color_texture.is_some();
            assert_eq!(textured, !mesh.uvs.is_empty(), "{name}/{}", mesh.name);
        }
    }
}

#[test]
fn spheres_have_several_tessellation_levels_and_are_watertight() {
    let c = capture_builtin("spheres", 1);
    let spheres: Vec<_> = c
        .scene
        .geometry
        .meshes
        .iter()
        .filter(|m| m.name.starts_with("sphere"))
        .collect();
    assert_eq!(spheres.len(), SPHERE_LEVELS.len());
    let counts: Vec<usize> = spheres.iter().map(|m| m.triangle_count()).collect();
    assert!(counts.windows(2).all(|w| w[1] == 4 * w[0]), "{counts:?}");
    let mut patches = std::collections::BTreeSet::new();
    for mesh in &spheres {
        assert_eq!(mesh.patch_ids.len(), mesh.triangle_count());
        assert!(mesh.uv_atlas_unique, "{}", mesh.name);
        patches.extend(mesh.patch_ids.iter().copied());
        // Closed: every edge (by exact vertex position) is used by exactly two triangles,
        // once in each direction.
        let key = |i: u32| mesh.positions[i as usize].to_array().map(f32::to_bits);
        let mut edges: BTreeMap<_, i32> = BTreeMap::new();
        for t in mesh.indices.chunks_exact(3) {
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                *edges.entry((key(a), key(b))).or_default() += 1;
            }
        }
        for (&(a, b), &n) in &edges {
            assert_eq!(n, 1, "{}: edge used {n} times one way", mesh.name);
            assert_eq!(edges.get(&(b, a)), Some(&1), "{}: open edge", mesh.name);
        }
    }
    assert_eq!(
        patches.len(),
        24 * SPHERE_LEVELS.len(),
        "patch ids unique across spheres"
    );

    let one_level = capture_builtin("spheres?subdiv=3", 1);
    let tris: Vec<usize> = one_level.scene.geometry.meshes[1..]
        .iter()
        .map(|m| m.triangle_count())
        .collect();
    assert!(tris.iter().all(|&t| t == 24 * 8 * 8 * 2), "{tris:?}");
}

#[test]
fn hairball_triangles_are_tiny_on_screen() {
    let c = capture_builtin("hairball", 1);
    let rig = c.frames[0].rig;
    let hair = &c.scene.geometry.meshes[0];
    let (w, h) = (rig.eye_width as f32, rig.eye_height as f32);
    for eye in Eye::BOTH {
        let m = rig.view_projection(eye);
        let to_px = |p: Vec3| {
            let clip = m * p.extend(1.0);
            let ndc = clip.xyz() / clip.w;
            glam::Vec2::new((ndc.x * 0.5 + 0.5) * w, (0.5 - ndc.y * 0.5) * h)
        };
        let areas: Vec<f32> = hair
            .indices
            .chunks_exact(3)
            .map(|t| {
                let [a, b, c] = [0, 1, 2].map(|k| to_px(hair.positions[t[k] as usize]));
                0.5 * (b - a).perp_dot(c - a).abs()
            })
            .collect();
        let mean = areas.iter().sum::<f32>() / areas.len() as f32;
        assert!(mean < 10.0, "{eye:?}: mean triangle area {mean} px");
        assert!(areas.len() > 40_000);
    }
}

#[test]
fn depth_stack_has_layers_and_light_room_has_many_lights() {
    let stack = capture_builtin("depth-stack", 1);
    let layers = stack
        .scene
        .geometry
        .meshes
        .iter()
        .filter(|m| m.name.starts_with("layer"))
        .count();
    assert!(layers >= 5);
    let room = capture_builtin("light-room", 1);
    let points = room
        .scene
        .lights
        .iter()
        .filter(|l| matches!(l.kind, LightKind::Point { .. }))
        .count();
    assert!(points >= 32);
    assert!(room.scene.geometry.meshes.iter().all(|m| m.motion == Motion::Static));
}

#[test]
fn bad_specs_and_options_are_errors() {
    let err = |input: &str, opts: CaptureOptions| {
        capture(&Input::parse(input), &opts, &mut |_, _| {})
            .unwrap_err()
            .to_string()
    };
    assert!(err("builtin:teapot", CaptureOptions::default()).contains("available: floor"));
    assert!(err("builtin:spheres?subdiv=99", CaptureOptions::default()).contains("subdiv"));
    assert!(err("builtin:floor?subdiv=1", CaptureOptions::default()).contains("unknown parameter"));
    let zero_frames = CaptureOptions {
        frames: 0,
        ..CaptureOptions::default()
    };
    assert!(err("builtin:floor", zero_frames).contains("--frames"));
    let nan_ipd = CaptureOptions {
        ipd_m: f32::NAN,
        ..CaptureOptions::default()
    };
    assert!(err("builtin:floor", nan_ipd).contains("--ipd"));
}

#[test]
fn extreme_rigs_still_capture() {
    for (ipd, (w, h)) in [(0.0, (1, 1)), (50.0, (7680, 4320)), (0.07, (16384, 16384))] {
        let opts = CaptureOptions {
            ipd_m: ipd,
            eye_width: w,
            eye_height: h,
            ..CaptureOptions::default()
        };
        let c = capture(&Input::Builtin("floor".into()), &opts, &mut |_, _| {}).unwrap();
        c.write(Vec::new(), 1).unwrap();
        if ipd == 0.0 {
            let rig = c.frames[0].rig;
            assert_eq!(rig.view_projection(Eye::Left), rig.view_projection(Eye::Right));
        }
    }
}

/// The paper-like arena: textured, sunlit with shadows, and a skinned character whose
/// vertices move from frame to frame while its triangles stay the same.
#[test]
fn arena_has_a_moving_skinned_dragon() {
    let c = capture_builtin("arena", 2);
    let f = c.meta.features;
    assert!(f.contains(Feature::Skinning) && f.contains(Feature::Textures) && f.contains(Feature::ShadowedLight));
    let dragon = c
        .scene
        .geometry
        .meshes
        .iter()
        .find(|m| matches!(m.motion, Motion::Skinned { .. }))
        .expect("a skinned mesh");
    let [a, b] = [&c.frames[0].skinned[0], &c.frames[1].skinned[0]];
    assert_eq!(a.positions.len(), dragon.positions.len());
    assert_eq!(b.positions.len(), dragon.positions.len());
    let moved = a
        .positions
        .iter()
        .zip(&b.positions)
        .filter(|(p, q)| (**p - **q).length() > 1e-3)
        .count();
    assert!(
        moved > dragon.positions.len() / 2,
        "{moved} of {} vertices moved",
        dragon.positions.len()
    );
    for n in &b.normals {
        assert!((n.length() - 1.0).abs() < 1e-4);
    }
}
