//! Surface maps (normal, metallic-roughness, occlusion, emissive) from glTF to pixels and
//! costs: each changes what it should and nothing else, costs its cost-table block per
//! lane, gives the same bits at any thread count, and the schemes whose stored inputs have
//! no channels for maps refuse them by name.

#[path = "../capture/tests/support/mod.rs"]
mod support;

use shadetrace_capture::{capture, CaptureOptions, Captured, Input};
use shadetrace_formats::LightKind;
use shadetrace_replay::cost_table::Block;
use shadetrace_replay::pipeline::{run_frame, CostHeat, FrameMode, PreparedScene};
use shadetrace_replay::preset::Preset;
use shadetrace_replay::ReplayOptions;
use support::MapsSpec;

fn captured(spec: MapsSpec) -> Captured {
    let dir = tempfile::tempdir().unwrap();
    let path = support::write_surface_maps_gltf(dir.path(), spec);
    capture(&Input::File(path), &CaptureOptions::default(), &mut |_, _| {}).unwrap()
}

/// One forward-family frame of `preset`: both views' pixels and instructions issued.
fn render(c: &Captured, preset: &str) -> (Vec<Vec<[u8; 4]>>, u64) {
    let preset = Preset::find(preset).unwrap();
    let opts = preset.resolve(&ReplayOptions {
        resolution: Some((64, 72)),
        ..ReplayOptions::default()
    });
    let prepared = PreparedScene::new(c.scene.clone());
    let scheduler = preset.scheduler(&opts).unwrap();
    let out = run_frame(
        &prepared,
        &c.meta,
        &c.frames[0],
        &opts,
        &*scheduler,
        &*preset.scheme(&opts),
        FrameMode::alone(CostHeat::Kept),
    );
    (
        out.views.iter().map(|v| v.pixels.clone()).collect(),
        out.views.iter().map(|v| v.cost.issued()).sum(),
    )
}

/// Pixels where two renders differ, and whether `a` is brighter (sum of RGB) at each.
fn brighter(a: &[Vec<[u8; 4]>], b: &[Vec<[u8; 4]>]) -> (usize, usize) {
    let (mut differ, mut up) = (0, 0);
    for (a, b) in a.iter().flatten().zip(b.iter().flatten()) {
        let sum = |p: &[u8; 4]| p[..3].iter().map(|&c| u32::from(c)).sum::<u32>();
        if a != b {
            differ += 1;
            up += usize::from(sum(a) > sum(b));
        }
    }
    (differ, up)
}

#[test]
fn emission_brightens_and_occlusion_darkens_only_the_surface() {
    let (plain, _) = render(&captured(MapsSpec::default()), "forward");
    let (glowing, _) = render(
        &captured(MapsSpec {
            emissive: true,
            ..Default::default()
        }),
        "forward",
    );
    let (occluded, _) = render(
        &captured(MapsSpec {
            occlusion: true,
            ..Default::default()
        }),
        "forward",
    );
    let (differ, up) = brighter(&glowing, &plain);
    assert!(
        differ > 50 && up == differ,
        "emission: {up} of {differ} changed pixels brighter"
    );
    let (differ, up) = brighter(&occluded, &plain);
    assert!(
        differ > 50 && up == 0,
        "occlusion: {up} of {differ} changed pixels brighter"
    );
}

/// A normal map tilting the normal toward the sun lights the quad; the same tilt away from
/// it lights nothing. The texel is chosen from the captured tangent frame, so the test does
/// not depend on which way MikkTSpace orients it.
#[test]
fn a_normal_map_bends_the_lighting_both_ways() {
    let probe = captured(MapsSpec {
        normal: Some([128, 128, 255, 255]),
        ..Default::default()
    });
    let mesh = &probe.scene.geometry.meshes[0];
    let t = probe.scene.surface_maps.tangents[0][0];
    let n = mesh.normals[0];
    let b = n.cross(t.truncate()) * t.w.signum();
    let LightKind::Directional { direction } = probe.scene.lights[0].kind else {
        panic!("the fixture's light is directional");
    };
    let toward = -direction.normalize();
    let in_plane = (toward - n * n.dot(toward)).normalize();
    // Tangent-space tilt of 0.4 toward the light, over the fixture's normal scale of 0.5.
    let texel = |sign: f32| {
        let encode = |v: f32| ((sign * 0.8 * v + 1.0) * 0.5 * 255.0).round() as u8;
        [encode(in_plane.dot(t.truncate())), encode(in_plane.dot(b)), 255, 255]
    };
    let flat = captured(MapsSpec::default());
    let (plain, plain_cost) = render(&flat, "forward");
    for (sign, want_brighter) in [(1.0, true), (-1.0, false)] {
        let c = captured(MapsSpec {
            normal: Some(texel(sign)),
            ..Default::default()
        });
        let (mapped, cost) = render(&c, "forward");
        let (differ, up) = brighter(&mapped, &plain);
        if want_brighter {
            assert!(differ > 50, "toward the light: only {differ} pixels changed");
            assert!(up * 10 > differ * 9, "toward the light: {up} of {differ} brighter");
        } else {
            // The quad faces across the sun (N·L = 0): tilted away it stays unlit.
            assert_eq!(up, 0, "away from the light: {up} of {differ} brighter");
        }
        assert!(cost > plain_cost);
    }
}

/// Every map costs its block on every lane that shades the surface: the extra
/// instructions are a whole number of lanes times the four blocks' cost.
#[test]
fn map_blocks_are_charged_per_lane() {
    let all = MapsSpec {
        normal: Some([200, 128, 200, 255]),
        metallic_roughness: true,
        occlusion: true,
        emissive: true,
        ..Default::default()
    };
    let per_lane: u32 = [
        Block::NormalMap,
        Block::MetallicRoughnessMap,
        Block::OcclusionMap,
        Block::EmissiveTextured,
    ]
    .iter()
    .map(|b| b.cost().alu + b.cost().tex)
    .sum();
    let (_, plain) = render(&captured(MapsSpec::default()), "forward");
    let (_, mapped) = render(&captured(all), "forward");
    let extra = mapped - plain;
    assert!(
        extra > 0 && extra % u64::from(per_lane) == 0,
        "{extra} extra, {per_lane} per lane"
    );
    let lanes = extra / u64::from(per_lane);
    assert_eq!(plain % lanes, 0, "every lane of the quad costs the same");
}

/// Multi-rate and object-space schemes sample the maps at their shading points, the visibility
/// buffer and reprojection at their pixels; all are the same at 1 and 2 threads, and the
/// G-buffer and DAIS schemes refuse the trace, naming the material.
#[test]
fn schemes_shade_maps_deterministically_or_refuse_them() {
    let c = captured(MapsSpec {
        normal: Some([200, 128, 200, 255]),
        metallic_roughness: true,
        occlusion: true,
        emissive: true,
        ..Default::default()
    });
    let (forward, _) = render(&c, "forward");
    let (visbuffer, _) = render(&c, "visbuffer");
    assert!(visbuffer == forward, "the visibility buffer shades as forward does");
    for preset in ["tile-pair", "amfs", "he-2x2", "repro-rt"] {
        let threads = |n: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .unwrap()
                .install(|| render(&c, preset))
        };
        assert!(threads(1) == threads(2), "{preset}: differs between 1 and 2 threads");
    }
    for preset in ["deferred", "tiled", "clustered", "dais", "dais-multirate"] {
        let e = Preset::find(preset).unwrap().supports(&c.scene).unwrap_err();
        assert!(e.contains("checker") && e.contains("surface maps"), "{preset}: {e}");
    }
}
