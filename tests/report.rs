//! `compare` writes a table, a CSV and a self-contained HTML report; bad presets fail cleanly.

mod common;

use common::shadetrace;

#[test]
fn compare_writes_csv_and_a_self_contained_report() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let o = shadetrace(
        &[
            "compare",
            "traces/floor.strace",
            "--presets",
            "forward,sort-middle,he-2x2,texel",
            "--res",
            "64x72",
            "--out",
            out,
            "--quiet",
        ],
        None,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut csv = csv::Reader::from_path(dir.path().join("summary.csv")).unwrap();
    let headers = csv.headers().unwrap().clone();
    let col = |name: &str| headers.iter().position(|h| h == name).unwrap();
    let rows: Vec<csv::StringRecord> = csv.records().map(|r| r.unwrap()).collect();
    assert_eq!(rows.len(), 3);
    assert_eq!(&rows[0][col("preset")], "forward");
    assert_eq!(rows[0][col("relative_cost_pct")].parse::<f64>().unwrap(), 100.0);
    assert_eq!(rows[1][col("min_ssim")].parse::<f64>().unwrap(), 1.0);
    assert!(rows[2][col("relative_cost_pct")].parse::<f64>().unwrap() < 100.0);
    // Per frame and view: 3 presets x 3 frames x 2 eyes, each view's own numbers.
    let mut frames = csv::Reader::from_path(dir.path().join("frames.csv")).unwrap();
    let fh = frames.headers().unwrap().clone();
    let fcol = |name: &str| fh.iter().position(|h| h == name).unwrap();
    let frows: Vec<csv::StringRecord> = frames.records().map(|r| r.unwrap()).collect();
    assert_eq!(frows.len(), 18);
    assert_eq!((&frows[0][fcol("eye")], &frows[1][fcol("eye")]), ("left", "right"));
    let issued: u64 = frows[12..18]
        .iter()
        .map(|r| r[fcol("issued")].parse::<u64>().unwrap())
        .sum();
    assert_eq!(issued.to_string(), rows[2][col("issued")]);
    assert!(frows[0][fcol("frame_texture_bytes")].parse::<u64>().unwrap() > 0);
    let html = std::fs::read_to_string(dir.path().join("index.html")).unwrap();
    assert!(html.contains("<svg") && html.contains("data:image/png;base64,"));
    // texel cannot run on the floor (no unique UV atlas): the report says so.
    assert!(
        html.contains("Not run on this trace: preset texel"),
        "skipped preset not reported"
    );
    assert!(
        !html.contains("src=\"http") && !html.contains("href=\"http"),
        "report must be self-contained"
    );
    for preset in ["forward", "sort-middle", "he-2x2"] {
        assert!(dir.path().join(preset).join("results.json").exists());
    }
    assert!(dir.path().join("he-2x2/frame0000-left-refine-shadow.png").exists());
}

#[test]
fn bad_preset_is_one_line_error() {
    let dir = tempfile::tempdir().unwrap();
    let o = shadetrace(
        &[
            "compare",
            "traces/floor.strace",
            "--presets",
            "forward,teapot",
            "--out",
            dir.path().to_str().unwrap(),
        ],
        None,
    );
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.starts_with("error: unknown preset `teapot`"), "{err}");
}

/// With the reference run, each view gets an error image against it; without, none.
#[test]
fn replay_writes_error_images_against_the_reference() {
    let dir = tempfile::tempdir().unwrap();
    let run = |label: &str, extra: &[&str]| {
        let out = dir.path().join(label);
        let out_arg = out.display().to_string();
        let mut args = vec![
            "replay",
            "traces/hairball.strace",
            "--preset",
            "amfs",
            "--res",
            "96x108",
            "--frames",
            "0",
            "--out",
            &out_arg,
            "--quiet",
        ];
        args.extend_from_slice(extra);
        assert!(shadetrace(&args, None).status.success());
        out
    };
    let with = run("with", &[]);
    for eye in ["left", "right"] {
        let error = image::open(with.join(format!("frame0000-{eye}-error.png"))).unwrap();
        assert!(
            error.width() >= 96 && error.height() > 108,
            "{eye}: the view and its legend"
        );
    }
    let without = run("without", &["--no-reference"]);
    assert!(!without.join("frame0000-left-error.png").exists());
}

/// `compare` of sort-middle on the floor trace with `--images images` at 48x54 over
/// `frames`, into a fresh directory.
fn compare_floor(images: &str, frames: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let args = [
        "compare",
        "traces/floor.strace",
        "--presets",
        "sort-middle",
        "--res",
        "48x54",
        "--frames",
        frames,
        "--images",
        images,
        "--out",
        out,
        "--quiet",
    ];
    let o = shadetrace(&args, None);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    dir
}

#[test]
fn compare_writes_the_pictures_of_the_frames_asked_for() {
    let pictures = |images: &str| {
        let dir = compare_floor(images, "1..3");
        let mut names: Vec<String> = std::fs::read_dir(dir.path().join("sort-middle"))
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".png"))
            .collect();
        names.sort();
        names
    };
    let first = pictures("first");
    assert!(
        !first.is_empty() && first.iter().all(|n| n.starts_with("frame0001-")),
        "{first:?}"
    );
    let all = pictures("all");
    assert_eq!(all.len(), 2 * first.len(), "{all:?}");
    assert!(all.iter().any(|n| n.starts_with("frame0002-")));
    assert!(pictures("none").is_empty());
    // Over several frames the report plots the cost and quality of each.
    let dir = compare_floor("none", "1..3");
    let svg = std::fs::read_to_string(dir.path().join("per-frame.svg")).unwrap();
    assert!(
        svg.contains(">\nframe\n</text>") && svg.contains(">\nsort-middle\n</text>"),
        "{svg}"
    );
    let html = std::fs::read_to_string(dir.path().join("index.html")).unwrap();
    assert!(html.contains("<a href=\"per-frame.svg\">") && html.contains("<a href=\"per-frame.png\">"));
    assert!(
        !compare_floor("none", "0").path().join("per-frame.svg").exists(),
        "one frame, no plot"
    );
}

#[test]
fn report_thumbnails_link_to_pictures_that_exist_and_show_error_maps() {
    let report = |images: &str| {
        let dir = compare_floor(images, "0");
        let html = std::fs::read_to_string(dir.path().join("index.html")).unwrap();
        let links: Vec<String> = html
            .split("<a href=\"")
            .skip(1)
            .filter_map(|rest| rest.split('"').next())
            .filter(|href| href.ends_with(".png"))
            .map(String::from)
            .collect();
        for link in &links {
            assert!(dir.path().join(link).is_file(), "{link} is linked but not written");
        }
        for figure in ["traffic", "cost-quality"] {
            let svg = std::fs::read_to_string(dir.path().join(format!("{figure}.svg"))).unwrap();
            assert!(
                svg.starts_with("<?xml") && svg.contains("xmlns=\"http://www.w3.org/2000/svg\""),
                "{figure}.svg opens on its own"
            );
            assert!(image::open(dir.path().join(format!("{figure}.png"))).is_ok());
        }
        (html, links)
    };
    let (html, links) = report("first");
    // Forward and sort-middle draw the same pixels: one thumbnail, captioned with both, and
    // each its own cost map.
    assert!(
        links.iter().any(|l| l == "forward/frame0000-stereo.png")
            && !links.iter().any(|l| l == "sort-middle/frame0000-stereo.png"),
        "{links:?}"
    );
    assert!(html.contains("<figcaption>forward = sort-middle</figcaption>"));
    assert!(
        links.iter().any(|l| l == "sort-middle/frame0000-left-cost.png"),
        "{links:?}"
    );
    // Every figure is also a standalone SVG and PNG beside the page, linked under it.
    for figure in ["traffic.svg", "traffic.png", "cost-quality.svg", "cost-quality.png"] {
        assert!(html.contains(&format!("<a href=\"{figure}\">")), "{figure} not linked");
    }
    assert!(html.contains("error against the reference") && html.contains("data:image/jpeg;base64,"));
    assert!(html.contains("SSIM loss against the reference") && html.contains("Pareto front"));
    assert!(
        links.iter().any(|l| l == "forward/frame0000-left-ssim.png"),
        "the SSIM map links to its file: {links:?}"
    );
    let (_, links) = report("none");
    assert!(
        links.iter().all(|l| !l.contains('/')),
        "no pictures written, only the figures beside the page linked: {links:?}"
    );
}
