//! `deferred`: a G-buffer pass, then lighting per pixel and triangle. Its pictures differ
//! from `forward`'s only by the G-buffer's quantization; it reports the G-buffer's size,
//! traffic and cache; under MSAA it lights each triangle of a pixel once.

mod common;

use common::{replay_into, trace};
use serde_json::Value;

fn replay(preset: &str, extra: &[&str]) -> Value {
    let dir = tempfile::tempdir().unwrap();
    let mut args = vec!["--res", "160x180", "--frames", "0"];
    args.extend_from_slice(extra);
    replay_into(&trace("spheres"), preset, &args, None, &dir.path().join("out"))
}

/// Frame 0 of spheres at 96x108 under `preset` and MSAA `msaa`, written into `dir`: its
/// results and its stereo picture's bytes.
fn spheres_frame(dir: &std::path::Path, preset: &str, msaa: &str) -> (serde_json::Value, Vec<u8>) {
    let out = dir.join(format!("{preset}-{msaa}"));
    let r = replay_into(
        &trace("spheres"),
        preset,
        &["--res", "96x108", "--frames", "0", "--msaa", msaa],
        None,
        &out,
    );
    (r, std::fs::read(out.join("frame0000-stereo.png")).unwrap())
}

#[test]
fn deferred_reports_its_g_buffer_and_loses_only_quantization() {
    let r = replay("deferred", &[]);
    let frame = &r["frames"][0];
    assert_eq!(
        frame["gbuffer_bytes"],
        2 * 160 * 180 * 20,
        "20 bytes per sample, both views"
    );
    assert!(
        frame["traffic"]["gbuffer"].as_u64().unwrap() > 0,
        "{}",
        frame["traffic"]
    );
    assert!(frame["caches"]["gbuffer"]["accesses"].as_u64().unwrap() > 0);
    for view in frame["views"].as_array().unwrap() {
        let cost = &view["cost"];
        assert!(cost["gbuffer"]["groups"].as_u64().unwrap() > 0 && cost["fine"]["groups"].as_u64().unwrap() > 0);
        // The lighting pass has no helper lanes: one lane per visible pixel at MSAA 1.
        assert_eq!(cost["fine"]["useful_lanes"], view["raster"]["pixels_covered"]);
        let ssim = view["quality"]["ssim"].as_f64().unwrap();
        assert!(
            ssim > 0.999 && ssim < 1.0,
            "albedo and normal quantization show: {ssim}"
        );
    }
    // Forward has no G-buffer and reports none.
    let forward = replay("forward", &["--no-reference"]);
    assert!(forward["frames"][0].get("gbuffer_bytes").is_none());
    assert!(forward["frames"][0]["caches"].get("gbuffer").is_none());
    assert!(forward["frames"][0]["traffic"].get("gbuffer").is_none());
}

#[test]
fn msaa_lights_each_triangle_of_a_pixel_once() {
    let r = replay("deferred", &["--msaa", "4"]);
    for view in r["frames"][0]["views"].as_array().unwrap() {
        let lanes = view["cost"]["fine"]["useful_lanes"].as_u64().unwrap();
        let (pixels, samples) = (
            view["raster"]["pixels_covered"].as_u64().unwrap(),
            view["raster"]["samples_passed"].as_u64().unwrap(),
        );
        assert!(
            lanes >= pixels && lanes < samples,
            "{pixels} pixels, {lanes} lit, {samples} samples"
        );
    }
    assert_eq!(r["frames"][0]["gbuffer_bytes"], 2 * 160 * 180 * 4 * 20);
}

/// Light lists are conservative: tiled and clustered light the same pixels as `deferred`,
/// and with many short-ranged lights they cost less, paying for lists they build and store.
#[test]
fn light_lists_keep_the_pixels_and_cut_the_lighting() {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("lights.strace").display().to_string();
    common::shadetrace_ok(
        &[
            "capture",
            "builtin:light-room?lights=256",
            "-o",
            &trace,
            "--frames",
            "1",
            "--quiet",
        ],
        None,
    );
    let run = |preset: &str| {
        let out = dir.path().join(preset);
        let r = replay_into(&trace, preset, &["--res", "128x144"], None, &out);
        (r, std::fs::read(out.join("frame0000-stereo.png")).unwrap())
    };
    let (deferred, pixels) = run("deferred");
    // The lighting pass's issued ALU instructions (left view).
    let issued = |r: &Value| r["frames"][0]["views"][0]["cost"]["fine"]["alu"].as_u64().unwrap();
    for preset in ["tiled", "clustered"] {
        let (r, p) = run(preset);
        assert!(p == pixels, "{preset} lights other pixels than deferred");
        let frame = &r["frames"][0];
        assert!(
            frame["traffic"]["light_lists"].as_u64().unwrap() > 0,
            "{preset}: {}",
            frame["traffic"]
        );
        assert!(frame["views"][0]["cost"]["light_lists"]["groups"].as_u64().unwrap() > 0);
        assert!(
            issued(&r) * 5 < issued(&deferred) * 4,
            "{preset}: lighting {} vs {}",
            issued(&r),
            issued(&deferred)
        );
    }
    assert!(deferred["frames"][0]["traffic"].get("light_lists").is_none());
}

/// The visibility buffer stores ids only and re-interpolates exactly what forward
/// interpolates, so its pixels are forward's bit for bit at any MSAA; it reports the buffer
/// and its traffic, and fetches triangles again when shading.
#[test]
fn the_visibility_buffer_gives_forwards_pixels() {
    let dir = tempfile::tempdir().unwrap();
    for msaa in ["1", "4"] {
        let run = |preset: &str| spheres_frame(dir.path(), preset, msaa);
        let ((vis, vis_pixels), (_, forward_pixels)) = (run("visbuffer"), run("forward"));
        assert!(
            vis_pixels == forward_pixels,
            "MSAA {msaa}: visbuffer's pixels differ from forward's"
        );
        let frame = &vis["frames"][0];
        let samples: u64 = msaa.parse().unwrap();
        assert_eq!(frame["visibility_bytes"], 2 * 96 * 108 * samples * 8);
        assert!(frame["traffic"]["visibility"].as_u64().unwrap() > 0);
        assert!(frame.get("gbuffer_bytes").is_none() && frame["traffic"].get("gbuffer").is_none());
        assert_eq!(frame["views"][0]["quality"]["ssim"], 1.0);
    }
}

/// A binned GPU lights each tile right after drawing it, while its G-buffer is on chip; an
/// immediate one lights after the whole frame, reading it back from DRAM.
#[test]
fn binned_schedulers_light_tiles_while_their_g_buffer_is_on_chip() {
    let dir = tempfile::tempdir().unwrap();
    let run = |preset: &str| {
        let out = dir.path().join(preset.replace('+', "-"));
        let r = replay_into(
            &trace("depth-stack"),
            preset,
            &["--res", "160x180", "--frames", "0", "--no-reference"],
            None,
            &out,
        );
        (r, std::fs::read(out.join("frame0000-stereo.png")).unwrap())
    };
    let ((immediate, a), (binned, b)) = (run("deferred"), run("sort-middle+deferred"));
    assert!(a == b, "the scheduler never changes pixels");
    let gbuffer = |r: &Value| r["frames"][0]["traffic"]["gbuffer"].as_u64().unwrap();
    assert!(
        gbuffer(&binned) * 2 < gbuffer(&immediate),
        "{} vs {}",
        gbuffer(&binned),
        gbuffer(&immediate)
    );
}

/// DAIS (Schied and Dachsbacher 2015) interpolates from the stored derivatives (Eq. 2):
/// its pictures are forward's up to f32 rounding of the extrapolation from the screen
/// centre and the analytic texture LOD; the list variant shades exactly the same; the
/// buffers add up as Table 1 counts them.
#[test]
fn dais_keeps_forwards_pixels_and_counts_its_buffers() {
    let dir = tempfile::tempdir().unwrap();
    let run = |preset: &str, msaa: &str| spheres_frame(dir.path(), preset, msaa);
    let (dais, _) = run("dais", "1");
    for view in dais["frames"][0]["views"].as_array().unwrap() {
        let q = &view["quality"];
        assert!(q["ssim"].as_f64().unwrap() > 0.9999, "{q}");
        assert!(q["max_abs_error"].as_u64().unwrap() <= 8, "{q}");
    }
    for msaa in [1u64, 4, 8] {
        let (samples, (list, list_pixels)) = (run("dais", &msaa.to_string()), run("dais-list", &msaa.to_string()));
        assert!(
            samples.1 == list_pixels,
            "MSAA {msaa}: the list shades what the samples do"
        );
        let pixels = 2 * 96 * 108;
        for (r, visibility) in [(&samples.0, pixels * msaa * 4), (&list, pixels * 4)] {
            let frame = &r["frames"][0];
            let d = &frame["dais"];
            assert_eq!(frame["visibility_bytes"], visibility);
            assert_eq!(d["depth_bytes"], pixels * msaa * 4);
            assert_eq!(d["memo_cache_bytes"], 81920, "2^13 entries and 2^12 locks");
            let (lookups, hits, misses) = (
                d["memo_lookups"].as_u64().unwrap(),
                d["memo_hits"].as_u64().unwrap(),
                d["memo_misses"].as_u64().unwrap(),
            );
            assert_eq!(hits + misses, lookups);
            assert!(misses > 0 && misses <= lookups, "{d}");
            assert_eq!(d["triangle_buffer_bytes"], misses * 80);
            let nodes = d.get("list_nodes").map_or(0, |n| n.as_u64().unwrap());
            assert_eq!(
                d["total_bytes"].as_u64().unwrap(),
                visibility + pixels * msaa * 4 + misses * 80 + nodes * 8
            );
            assert!(frame["traffic"]["triangle_buffer"].as_u64().unwrap() >= 3 * misses * 80);
            for view in frame["views"].as_array().unwrap() {
                assert!(view["cost"]["derivatives"]["useful_lanes"].as_u64().unwrap() > 0);
            }
        }
        let nodes = list["frames"][0]["dais"]["list_nodes"].as_u64().unwrap();
        if msaa == 1 {
            assert_eq!(nodes, 0, "every fragment covers its pixel's one sample");
        } else {
            assert!(nodes > 0 && nodes < pixels, "nodes only at edges: {nodes}");
        }
    }
}

/// A memoization cache too small for the triangles in flight evicts them, and a triangle
/// seen again is stored again: more stores, never other pixels.
#[test]
fn a_small_memoization_cache_stores_triangles_twice() {
    let dir = tempfile::tempdir().unwrap();
    let run = |entries: &str| {
        let out = dir.path().join(entries);
        let r = replay_into(
            &trace("depth-stack"),
            "sort-middle+dais",
            &["--res", "160x180", "--frames", "0", "--memo-entries", entries],
            None,
            &out,
        );
        (r, std::fs::read(out.join("frame0000-stereo.png")).unwrap())
    };
    let ((big, a), (small, b)) = (run("8192"), run("2"));
    assert!(a == b);
    let d = |r: &Value, k: &str| r["frames"][0]["dais"][k].as_u64().unwrap();
    assert_eq!(d(&big, "redundant_stores"), 0);
    assert!(d(&small, "redundant_stores") > 0 && d(&small, "memo_misses") > d(&big, "memo_misses"));
    assert_eq!(d(&small, "memo_cache_bytes"), 2 * 8 + 4);
}

/// Multi-rate DAIS lights once per 2x2 shading quad its triangle covers whole: between a
/// quarter of the shaded pixels and all of them, for a little quality.
#[test]
fn dais_multirate_lights_at_a_quarter_of_the_rate() {
    let r = replay("dais-multirate", &[]);
    let frame = &r["frames"][0];
    let samples = frame["dais"]["shading_samples"].as_u64().unwrap();
    let lit: u64 = frame["views"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v["cost"]["fine"]["useful_lanes"].as_u64().unwrap())
        .sum();
    assert!(
        samples * 4 >= lit && samples < lit / 2,
        "{samples} samples, {lit} pixels"
    );
    assert!(frame["traffic"]["shading_samples"].as_u64().unwrap() == 2 * 12 * samples);
    for view in frame["views"].as_array().unwrap() {
        assert!(view["cost"]["coarse"]["useful_lanes"].as_u64().unwrap() > 0);
        let ssim = view["quality"]["ssim"].as_f64().unwrap();
        assert!(ssim > 0.99 && ssim < 1.0, "{ssim}");
    }
    assert!(
        r["total"]["relative_cost"].as_f64().unwrap() < replay("dais", &[])["total"]["relative_cost"].as_f64().unwrap()
    );
}

/// The deferred family at the extremes: 1x1 and 2x3 views at MSAA 8, and empty views.
#[test]
fn the_deferred_family_survives_tiny_and_empty_views() {
    let dir = tempfile::tempdir().unwrap();
    // A camera that looks away from everything.
    let empty = dir.path().join("empty.strace").display().to_string();
    let fly = dir.path().join("away.toml");
    std::fs::write(
        &fly,
        "[[key]]\ntime = 0.0\nposition = [0.0, 50.0, 0.0]\nlook_at = [0.0, 100.0, 1.0]\n",
    )
    .unwrap();
    let fly = fly.display().to_string();
    let capture = [
        "capture",
        "builtin:light-room",
        "-o",
        &empty,
        "--path",
        &fly,
        "--res",
        "32x32",
        "--frames",
        "1",
    ];
    common::shadetrace_ok(&capture, None);
    for preset in [
        "deferred",
        "tiled",
        "clustered",
        "visbuffer",
        "dais",
        "dais-list",
        "dais-multirate",
    ] {
        for (scene, res) in [
            (trace("light-room"), "1x1"),
            (trace("light-room"), "2x3"),
            (empty.clone(), "32x32"),
        ] {
            let out = dir.path().join(format!("{preset}-{res}"));
            let r = replay_into(
                &scene,
                preset,
                &["--res", res, "--frames", "0", "--msaa", "8"],
                None,
                &out,
            );
            common::assert_sane(&r, &format!("{preset} {res}"));
            if res == "32x32" {
                assert_eq!(
                    r["total"]["cost"]["fine"]["groups"].as_u64(),
                    Some(0),
                    "{preset}: nothing to shade"
                );
            }
        }
    }
}

/// No light at all, and one light whose range covers the whole room: the lists hold
/// nothing or everything, and every deferred scheme keeps its relation to `forward`.
#[test]
fn zero_lights_and_a_light_covering_the_view() {
    let dir = tempfile::tempdir().unwrap();
    for n in ["0", "1"] {
        let trace = dir.path().join(format!("lights{n}.strace")).display().to_string();
        let scene = format!("builtin:light-room?lights={n}");
        common::shadetrace_ok(&["capture", &scene, "-o", &trace, "--frames", "1", "--quiet"], None);
        let run = |preset: &str| {
            let out = dir.path().join(format!("{preset}-{n}"));
            let r = replay_into(&trace, preset, &["--res", "64x72", "--msaa", "4"], None, &out);
            (r, std::fs::read(out.join("frame0000-stereo.png")).unwrap())
        };
        let (deferred, deferred_pixels) = run("deferred");
        common::assert_sane(&deferred, n);
        for preset in ["tiled", "clustered"] {
            assert!(
                run(preset).1 == deferred_pixels,
                "{n} lights: {preset} differs from deferred"
            );
        }
        let (_, forward_pixels) = run("forward");
        assert!(
            run("visbuffer").1 == forward_pixels,
            "{n} lights: visbuffer differs from forward"
        );
        let (dais, _) = run("dais");
        assert!(
            dais["total"]["min_ssim"].as_f64().unwrap() > 0.999,
            "{n} lights: {}",
            dais["total"]
        );
    }
}
