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
        let run = |preset: &str| {
            let out = dir.path().join(format!("{preset}-{msaa}"));
            let r = replay_into(
                &trace("spheres"),
                preset,
                &["--res", "96x108", "--frames", "0", "--msaa", msaa],
                None,
                &out,
            );
            (r, std::fs::read(out.join("frame0000-stereo.png")).unwrap())
        };
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
