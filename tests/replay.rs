//! Replay through the command line: golden numbers, determinism across thread counts,
//! numbers that do not depend on pictures being written, scheduling that changes cost and
//! traffic but never pixels, the Table 1 list-memory trend, and the extremes (1x1 and empty
//! views).

mod common;

use std::path::{Path, PathBuf};

use common::{replay_into, shadetrace_ok as shadetrace, trace};
use serde_json::Value;

/// Replays and returns results.json (timing removed) and the output directory.
fn replay(name: &str, preset: &str, extra: &[&str], threads: Option<&str>, dir: &Path) -> (Value, PathBuf) {
    let out = dir.join(format!(
        "{name}-{preset}-{}-{}",
        extra.join("_"),
        threads.unwrap_or("default")
    ));
    (replay_into(&trace(name), preset, extra, threads, &out), out)
}

#[test]
fn goldens_hold() {
    let out = shadetrace(&["check"], None);
    assert!(String::from_utf8_lossy(&out.stdout).contains("golden checks passed"));
}

#[test]
fn identical_results_and_images_at_any_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    for (name, preset) in [
        ("spheres", "sort-middle"),
        ("hairball", "forward"),
        ("depth-stack", "he-dynamic"),
        ("light-room", "deferred"),
        ("spheres", "dais-multirate"),
        ("depth-stack", "repro-rt"),
        ("arena", "repro-reraster"),
    ] {
        let res = ["--res", "160x180"];
        let (one, dir1) = replay(name, preset, &res, Some("1"), dir.path());
        let (two, dir2) = replay(name, preset, &res, Some("2"), dir.path());
        assert_eq!(one, two, "{name}/{preset}: results differ between 1 and 2 threads");
        for file in [
            "frame0000-left.png",
            "frame0000-right.png",
            "frame0002-stereo.png",
            "frame0001-left-cost.png",
        ] {
            let a = std::fs::read(dir1.join(file)).unwrap();
            let b = std::fs::read(dir2.join(file)).unwrap();
            assert!(a == b, "{name}/{preset}: {file} differs between thread counts");
        }
    }
}

/// A replay that writes no pictures skips their cost heat maps and keeps no images, and one
/// without the reference either skips its colours: every number is the same (a multi-rate
/// scheme that reports refinement, a stereo scheduler, a view pass).
#[test]
fn replays_without_pictures_count_the_same() {
    let dir = tempfile::tempdir().unwrap();
    for (name, preset) in [
        ("depth-stack", "he-dynamic"),
        ("spheres", "tile-pair"),
        ("arena", "repro-reraster"),
    ] {
        let (with, _) = replay(name, preset, &["--res", "160x180"], None, dir.path());
        let (without, out) = replay(name, preset, &["--res", "160x180", "--no-images"], None, dir.path());
        assert_eq!(with, without, "{name}/{preset}: --no-images changed the results");
        let pictures = std::fs::read_dir(&out)
            .unwrap()
            .filter(|e| e.as_ref().unwrap().path().extension().is_some_and(|x| x == "png"))
            .count();
        assert_eq!(pictures, 0, "{name}/{preset}: --no-images wrote pictures");
        let bare = ["--res", "160x180", "--no-images", "--no-reference"];
        let (colourless, _) = replay(name, preset, &bare, None, dir.path());
        assert_eq!(
            counters(&with),
            counters(&colourless),
            "{name}/{preset}: skipping the colours changed a counter"
        );
    }
}

/// Every counter of a results.json that does not compare with the reference.
fn counters(results: &Value) -> Vec<&Value> {
    let mut counters = Vec::new();
    for frame in results["frames"].as_array().unwrap() {
        for key in ["traffic", "caches", "lists", "shadow_pass"] {
            counters.push(&frame[key]);
        }
        for view in frame["views"].as_array().unwrap() {
            for key in ["vertex", "raster", "cost", "refined_pixels", "shading_cache"] {
                counters.push(&view[key]);
            }
        }
    }
    counters
}

/// `forward` run against the reference records a copy of the reference's replay instead of
/// replaying it again: its counters and pictures are those of a replay on its own.
#[test]
fn the_reference_preset_against_the_reference_is_its_own_replay() {
    let dir = tempfile::tempdir().unwrap();
    let res = ["--res", "160x180", "--frames", "0..2"];
    let (with, with_dir) = replay("spheres", "forward", &res, None, dir.path());
    let alone_args = [&res[..], &["--no-reference"]].concat();
    let (alone, alone_dir) = replay("spheres", "forward", &alone_args, None, dir.path());
    let frames = with["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 2);
    for (f, frame) in frames.iter().enumerate() {
        let other = &alone["frames"][f];
        for key in ["traffic", "caches", "lists"] {
            assert_eq!(frame[key], other[key], "frame {f} {key}");
        }
        for v in 0..2 {
            for key in ["vertex", "raster", "cost"] {
                assert_eq!(
                    frame["views"][v][key], other["views"][v][key],
                    "frame {f} view {v} {key}"
                );
            }
            assert_eq!(frame["views"][v]["quality"]["ssim"], 1.0, "frame {f} view {v}");
        }
    }
    for name in ["frame0000-left.png", "frame0001-right.png", "frame0001-left-cost.png"] {
        assert_eq!(
            std::fs::read(with_dir.join(name)).unwrap(),
            std::fs::read(alone_dir.join(name)).unwrap(),
            "{name}"
        );
    }
}

#[test]
fn scheduling_changes_traffic_never_pixels() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["floor", "spheres", "hairball", "depth-stack", "light-room"] {
        let res = ["--res", "160x180", "--frames", "0"];
        let (forward, fdir) = replay(name, "forward", &res, None, dir.path());
        let (sort, sdir) = replay(name, "sort-middle", &res, None, dir.path());
        for file in ["frame0000-left.png", "frame0000-right.png"] {
            assert!(
                std::fs::read(fdir.join(file)).unwrap() == std::fs::read(sdir.join(file)).unwrap(),
                "{name}: {file}"
            );
        }
        assert_eq!(sort["total"]["relative_cost"].as_f64(), Some(1.0), "{name}");
        assert_eq!(sort["total"]["min_ssim"].as_f64(), Some(1.0), "{name}");
        let dc = |v: &Value| v["total"]["traffic"]["depth_color"].as_u64().unwrap();
        assert!(
            dc(&sort) < dc(&forward),
            "{name}: sort-middle depth/color {} >= forward {}",
            dc(&sort),
            dc(&forward)
        );
        assert_eq!(forward["total"]["traffic"]["indices"].as_u64(), Some(0));
    }
}

#[test]
fn list_memory_grows_as_tiles_shrink() {
    let dir = tempfile::tempdir().unwrap();
    let bytes: Vec<u64> = ["8", "16", "32"]
        .iter()
        .map(|tile| {
            let (v, _) = replay(
                "spheres",
                "sort-middle",
                &["--tile", tile, "--frames", "0", "--no-images"],
                None,
                dir.path(),
            );
            v["frames"][0]["lists"]["tile_list_bytes"].as_u64().unwrap()
        })
        .collect();
    assert!(bytes[0] > bytes[1] && bytes[1] > bytes[2], "{bytes:?}");
}

#[test]
fn tiny_and_empty_views_replay_without_nan() {
    let dir = tempfile::tempdir().unwrap();
    for res in ["1x1", "2x3"] {
        let (v, _) = replay(
            "floor",
            "sort-middle",
            &["--res", res, "--frames", "0"],
            None,
            dir.path(),
        );
        common::assert_sane(&v, res);
        // Scheduling never changes pixels, at any size.
        for view in v["frames"][0]["views"].as_array().unwrap() {
            assert_eq!(view["quality"]["max_abs_error"].as_u64(), Some(0), "{res}");
        }
    }
    // A scene whose camera looks away from everything: empty views.
    let empty = dir.path().join("empty.strace");
    let fly = dir.path().join("away.toml");
    std::fs::write(
        &fly,
        "[[key]]\ntime = 0.0\nposition = [0.0, 50.0, 0.0]\nlook_at = [0.0, 100.0, 1.0]\n",
    )
    .unwrap();
    shadetrace(
        &[
            "capture",
            "builtin:light-room",
            "-o",
            empty.to_str().unwrap(),
            "--path",
            fly.to_str().unwrap(),
            "--res",
            "32x32",
            "--quiet",
        ],
        None,
    );
    let out = dir.path().join("empty-out");
    shadetrace(
        &[
            "replay",
            empty.to_str().unwrap(),
            "--preset",
            "sort-middle",
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ],
        None,
    );
    let v: Value = serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    assert_eq!(v["total"]["cost"]["fine"]["groups"].as_u64(), Some(0));
}

#[test]
fn an_8k_view_replays() {
    let dir = tempfile::tempdir().unwrap();
    let (v, _) = replay(
        "depth-stack",
        "sort-middle",
        &[
            "--res",
            "7680x4320",
            "--frames",
            "0",
            "--no-images",
            "--no-reference",
            "--shadow-map",
            "512",
        ],
        None,
        dir.path(),
    );
    assert_eq!(v["eye_width"].as_u64(), Some(7680));
    // Both views together shade more than one view's worth of pixels (overdraw included).
    assert!(v["total"]["shaded_pixels"].as_u64().unwrap() > 7680 * 4320 / 2);
}
