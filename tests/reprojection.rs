//! Hybrid reprojection (Wißmann et al. 2020): the right view warped from the left one, its
//! holes ray traced (`repro-rt`) or re-rasterized (`repro-reraster`). Coinciding eyes leave
//! no hole and copy the left view exactly; eyes far apart leave almost only holes, which
//! are shaded as `forward` shades them; the grid follows the parallax threshold.

mod common;

use std::path::Path;

use common::{replay_into, shadetrace_ok, trace};
use serde_json::Value;

fn capture(dir: &Path, scene: &str, ipd: &str) -> String {
    let out = dir.join(format!("{}-{ipd}.strace", scene.replace(['?', '=', ':'], "_")));
    let out_s = out.display().to_string();
    shadetrace_ok(
        &[
            "capture", scene, "-o", &out_s, "--ipd", ipd, "--res", "96x108", "--quiet",
        ],
        None,
    );
    out_s
}

/// Replays and returns the results and the right view's pixels (RGB).
fn run(trace: &str, preset: &str, extra: &[&str], dir: &Path) -> (Value, Vec<u8>) {
    let out = dir.join(format!(
        "{}-{preset}-{}",
        Path::new(trace).file_stem().unwrap().to_string_lossy(),
        extra.join("_")
    ));
    let r = replay_into(trace, preset, extra, None, &out);
    let right = image::open(out.join("frame0000-right.png"))
        .unwrap()
        .to_rgb8()
        .into_raw();
    (r, right)
}

fn stats(r: &Value, key: &str) -> u64 {
    r["frames"][0]["reprojection"][key].as_u64().unwrap()
}

/// The right view's issued instructions per stage.
fn right_stages(r: &Value) -> Vec<(String, u64)> {
    let cost = r["frames"][0]["views"][1]["cost"].as_object().unwrap();
    cost.iter()
        .filter_map(|(k, v)| Some((k.clone(), v.get("alu")?.as_u64()? + v["tex"].as_u64()?)))
        .filter(|(_, n)| *n > 0)
        .collect()
}

#[test]
fn coinciding_eyes_leave_no_hole_and_copy_the_left_view() {
    let dir = tempfile::tempdir().unwrap();
    let t = capture(dir.path(), "builtin:spheres", "0");
    for preset in ["repro-rt", "repro-reraster"] {
        let out = dir.path().join(preset);
        let r = replay_into(&t, preset, &[], None, &out);
        assert_eq!(stats(&r, "hole_pixels"), 0, "{preset}");
        assert_eq!(stats(&r, "cells_tessellated"), 0, "{preset}");
        assert_eq!(stats(&r, "reprojected_pixels"), 96 * 108);
        let left = std::fs::read(out.join("frame0000-left.png")).unwrap();
        let right = std::fs::read(out.join("frame0000-right.png")).unwrap();
        assert!(left == right, "{preset}: the right view is the left one");
        let stages: Vec<String> = right_stages(&r).into_iter().map(|(s, _)| s).collect();
        assert_eq!(stages, ["warp"], "{preset}: the right view costs only the warp");
    }
}

#[test]
fn eyes_far_apart_leave_holes_shaded_as_forward_shades_them() {
    let dir = tempfile::tempdir().unwrap();
    let t = capture(dir.path(), "builtin:light-room", "5");
    let (forward, forward_right) = run(&t, "forward", &[], dir.path());
    let (rt, rt_right) = run(&t, "repro-rt", &[], dir.path());
    let (reraster, reraster_right) = run(&t, "repro-reraster", &[], dir.path());
    let pixels = 96 * 108;
    let holes = stats(&rt, "hole_pixels");
    assert!(holes * 100 >= pixels * 95, "{holes} of {pixels} pixels are holes");
    assert_eq!(stats(&rt, "rays"), holes);
    assert_eq!(stats(&reraster, "hole_pixels"), holes, "the same warp");
    // Re-rasterized holes are the visibility buffer's pixels, which are forward's; rays hit
    // the same surfaces and shade them with the same shader, their barycentrics computed
    // in world space rather than from the rasterizer's fixed-point edges: within one step.
    let differing = |a: &[u8], b: &[u8], by: u8| {
        a.chunks(3)
            .zip(b.chunks(3))
            .filter(|(p, q)| p.iter().zip(*q).any(|(x, y)| x.abs_diff(*y) > by))
            .count() as u64
    };
    assert!(
        differing(&reraster_right, &forward_right, 0) <= pixels - holes,
        "only reprojected pixels differ"
    );
    assert_eq!(
        differing(&rt_right, &reraster_right, 1),
        0,
        "rays and raster agree within 1"
    );
    // A ray-traced view costs about a second view's shading (less: no helper lanes, no
    // overdraw), plus the traversal.
    let stage = |r: &Value, s: &str| right_stages(r).into_iter().find(|(k, _)| k == s).map_or(0, |(_, n)| n);
    let second_view = stage(&forward, "fine");
    let shading = stage(&rt, "ray");
    assert!(
        shading * 3 > second_view && shading < second_view * 2,
        "{shading} vs {second_view}"
    );
    assert!(stage(&rt, "traversal") > 0 && stage(&rt, "bvh_build") > 0);
    assert!(stats(&rt, "node_visits") >= holes && stats(&rt, "bvh_bytes") > 0);
    assert!(rt["frames"][0]["traffic"]["bvh"].as_u64().unwrap() > 0);
    // Re-rasterizing processes all geometry of the right view again.
    let triangles = |r: &Value| r["frames"][0]["views"][1]["vertex"]["triangles_in"].as_u64().unwrap();
    assert_eq!(triangles(&reraster), triangles(&forward));
    assert_eq!(triangles(&rt), 0);
}

#[test]
fn the_grid_follows_the_parallax_threshold() {
    let dir = tempfile::tempdir().unwrap();
    let counts: Vec<(u64, u64)> = ["0.25", "1", "4"]
        .iter()
        .map(|threshold| {
            let out = dir.path().join(threshold);
            let r = replay_into(
                &trace("arena"),
                "repro-rt",
                &[
                    "--res",
                    "320x360",
                    "--frames",
                    "0",
                    "--no-reference",
                    "--no-images",
                    "--parallax-threshold",
                    threshold,
                ],
                None,
                &out,
            );
            (stats(&r, "grid_triangles"), stats(&r, "cells_tessellated"))
        })
        .collect();
    assert!(
        counts.windows(2).all(|w| w[0].0 >= w[1].0 && w[0].1 >= w[1].1) && counts[0].0 > counts[2].0,
        "a looser threshold tessellates less: {counts:?}"
    );
}

#[test]
fn reprojection_survives_the_extremes() {
    let dir = tempfile::tempdir().unwrap();
    // The near plane inside a wall: the camera 2 cm from it, looking along it.
    let fly = dir.path().join("wall.toml");
    std::fs::write(
        &fly,
        "[[key]]\ntime = 0.0\nposition = [3.98, 1.5, 0.0]\nlook_at = [3.98, 1.5, -1.0]\n",
    )
    .unwrap();
    let wall = dir.path().join("wall.strace").display().to_string();
    let fly = fly.display().to_string();
    shadetrace_ok(
        &[
            "capture",
            "builtin:light-room",
            "-o",
            &wall,
            "--path",
            &fly,
            "--res",
            "48x54",
            "--quiet",
        ],
        None,
    );
    for preset in ["repro-rt", "repro-reraster"] {
        for (scene, extra) in [
            (trace("floor"), vec!["--res", "1x1", "--frames", "0"]),
            (trace("arena"), vec!["--res", "2x3", "--frames", "0", "--msaa", "4"]),
            (wall.clone(), vec![]),
        ] {
            let out = dir.path().join(format!("{preset}-{}", extra.join("_")));
            let r = replay_into(&scene, preset, &extra, None, &out);
            common::assert_sane(&r, &format!("{preset} {extra:?}"));
        }
    }
}

/// `frames.csv` (and so a sweep's store) carries the reprojection counters per frame, as
/// `repro_FIELD` columns, empty for presets that do not report them.
#[test]
fn frames_csv_carries_the_reprojection_counters() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cmp");
    let out_s = out.display().to_string();
    shadetrace_ok(
        &[
            "compare",
            &trace("arena"),
            "--presets",
            "repro-rt",
            "--res",
            "64x72",
            "--frames",
            "0",
            "--images",
            "none",
            "--out",
            &out_s,
            "--quiet",
        ],
        None,
    );
    let mut csv = csv::Reader::from_path(out.join("frames.csv")).unwrap();
    let header = csv.headers().unwrap().clone();
    let column = header
        .iter()
        .position(|h| h == "repro_hole_pixels")
        .expect("a hole column");
    let preset = header.iter().position(|h| h == "preset").unwrap();
    let results = common::results(&out.join("repro-rt"));
    let holes = results["frames"][0]["reprojection"]["hole_pixels"].to_string();
    for row in csv.records() {
        let row = row.unwrap();
        match &row[preset] {
            "repro-rt" => assert_eq!(&row[column], holes),
            _ => assert_eq!(&row[column], "", "the reference reports no holes"),
        }
    }
}

/// `--specular-error` measures what carrying the left eye's shading costs: nothing when the
/// eyes coincide, something on the room's glossy surfaces when they are apart; without the
/// flag nothing is measured or reported.
#[test]
fn the_specular_only_error_is_zero_only_when_the_eyes_coincide() {
    let dir = tempfile::tempdir().unwrap();
    for (ipd, nonzero) in [("0", false), ("0.5", true)] {
        let t = capture(dir.path(), "builtin:light-room", ipd);
        let (r, _) = run(&t, "repro-rt", &["--specular-error"], dir.path());
        let e = &r["frames"][0]["reprojection"]["specular_error"];
        let (sum, max, pixels) = (
            e["sum"].as_u64().unwrap(),
            e["max"].as_u64().unwrap(),
            e["pixels"].as_u64().unwrap(),
        );
        assert_eq!(pixels > 0, nonzero, "IPD {ipd}: {e}");
        assert!(sum >= pixels && max <= 255 && pixels <= stats(&r, "reprojected_pixels"));
        let (plain, _) = run(&t, "repro-rt", &[], dir.path());
        assert!(plain["frames"][0]["reprojection"].get("specular_error").is_none());
    }
}

/// `--grid-cell` sets the warping grid's cells; `--bvh-cache-kb` the cache BVH fetches go
/// through (a smaller one misses more, never changing the pixels).
#[test]
fn grid_cell_and_bvh_cache_options_take_effect() {
    let dir = tempfile::tempdir().unwrap();
    let t = capture(dir.path(), "builtin:light-room", "0.5");
    let (eight, _) = run(&t, "repro-rt", &["--grid-cell", "8", "--no-reference"], dir.path());
    assert_eq!(stats(&eight, "grid_cells"), 96_u64.div_ceil(8) * 108_u64.div_ceil(8));
    let (small, a) = run(&t, "repro-rt", &["--bvh-cache-kb", "1", "--no-reference"], dir.path());
    let (large, b) = run(&t, "repro-rt", &["--bvh-cache-kb", "256", "--no-reference"], dir.path());
    assert!(a == b);
    let misses = |r: &Value| r["frames"][0]["caches"]["bvh"]["misses"].as_u64().unwrap();
    assert!(
        misses(&small) > misses(&large),
        "{} vs {}",
        misses(&small),
        misses(&large)
    );
}
