//! The command line as users and CI scripts drive it: capture from glTF and built-in scenes,
//! `info`, and bad inputs that must give one line on stderr, a non-zero exit code and no
//! output file.

#[path = "../capture/tests/support/mod.rs"]
mod support;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn shadetrace(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_shadetrace"))
        .args(args)
        .output()
        .unwrap()
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Captures `input` to `out` with small views and returns `info`'s output.
fn capture_and_info(input: &str, out: &Path, extra: &[&str]) -> String {
    let mut args = vec![
        "capture",
        input,
        "-o",
        out.to_str().unwrap(),
        "--res",
        "64x72",
        "--quiet",
    ];
    args.extend_from_slice(extra);
    let o = shadetrace(&args);
    assert!(o.status.success(), "capture {input} failed: {}", stderr(&o));
    let info = shadetrace(&["info", out.to_str().unwrap()]);
    assert!(info.status.success(), "info failed: {}", stderr(&info));
    stdout(&info)
}

fn line<'a>(info: &'a str, key: &str) -> &'a str {
    info.lines()
        .find(|l| l.starts_with(key))
        .unwrap_or_else(|| panic!("no {key} line in {info}"))
}

#[test]
fn captures_gltf_with_external_files_glb_and_skinned_animation() {
    let dir = tempfile::tempdir().unwrap();
    let gltf = support::write_textured_gltf(dir.path());
    let info = capture_and_info(gltf.to_str().unwrap(), &dir.path().join("a.strace"), &[]);
    assert!(line(&info, "features").contains("textures"), "{info}");
    assert!(line(&info, "features").contains("shadowed-light"), "{info}");
    assert!(line(&info, "content hash").contains("(verified)"));

    let glb = support::write_textured_glb(dir.path());
    let info_glb = capture_and_info(glb.to_str().unwrap(), &dir.path().join("b.strace"), &[]);
    assert_eq!(line(&info, "counts"), line(&info_glb, "counts"));

    let skinned = support::write_skinned_animated_gltf(dir.path());
    let info = capture_and_info(
        skinned.to_str().unwrap(),
        &dir.path().join("c.strace"),
        &["--frames", "4"],
    );
    let features = line(&info, "features");
    assert!(
        features.contains("skinning") && features.contains("animation"),
        "{info}"
    );
    assert!(
        !features.contains("textures"),
        "untextured file flagged textured: {info}"
    );
    assert!(line(&info, "motion").contains("skinned"));
}

#[test]
fn flythrough_and_camera_paths() {
    let dir = tempfile::tempdir().unwrap();
    let toml = dir.path().join("fly.toml");
    std::fs::write(
        &toml,
        "fov_deg = 80\n[[key]]\ntime = 0.0\nposition = [0.0, 1.6, 5.0]\nlook_at = [0.0, 1.0, 0.0]\n\
         [[key]]\ntime = 2.0\nposition = [5.0, 1.6, 0.0]\nlook_at = [0.0, 1.0, 0.0]\n",
    )
    .unwrap();
    let info = capture_and_info(
        "builtin:floor",
        &dir.path().join("fly.strace"),
        &["--frames", "3", "--path", toml.to_str().unwrap()],
    );
    assert!(line(&info, "capture").contains("flythrough:fly.toml"), "{info}");
    let gltf = support::write_textured_gltf(dir.path());
    let info = capture_and_info(
        gltf.to_str().unwrap(),
        &dir.path().join("cam.strace"),
        &["--path", "camera:0"],
    );
    assert!(line(&info, "capture").contains("camera:0"));
}

fn hash_line(out: &Output) -> String {
    stdout(out)
        .lines()
        .find(|l| l.starts_with("content hash"))
        .unwrap()
        .to_string()
}

#[test]
fn same_input_same_hash_whatever_the_zstd_level() {
    let dir = tempfile::tempdir().unwrap();
    let run = |name: &str, level: &str| {
        let out = dir.path().join(name);
        let o = shadetrace(&[
            "capture",
            "builtin:spheres",
            "-o",
            out.to_str().unwrap(),
            "--res",
            "64x72",
            "--zstd-level",
            level,
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        (hash_line(&o), std::fs::metadata(&out).unwrap().len())
    };
    let (h1, size1) = run("a.strace", "3");
    let (h2, _) = run("b.strace", "3");
    let (h3, size3) = run("c.strace", "19");
    assert_eq!(h1, h2);
    assert_eq!(h1, h3);
    assert_ne!(size1, size3, "levels should change the bytes, not the hash");
}

/// Asserts a failing command: non-zero exit, exactly one `error:` line, naming `needle`,
/// and no file at `out`.
fn assert_clean_failure(o: &Output, needle: &str, out: Option<&PathBuf>) {
    assert!(!o.status.success(), "expected failure, got success");
    let err = stderr(o);
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "expected one line, got {err:?}");
    assert!(lines[0].starts_with("error: "), "{err}");
    assert!(lines[0].contains(needle), "{err:?} does not mention {needle:?}");
    if let Some(out) = out {
        assert!(!out.exists(), "partial output left at {}", out.display());
        let leftovers: Vec<_> = std::fs::read_dir(out.parent().unwrap())
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().contains(".tmp"))
            .collect();
        assert!(leftovers.is_empty(), "temporary files left behind");
    }
}

#[test]
fn bad_gltf_inputs_fail_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.strace");
    let cases: Vec<(PathBuf, &str)> = vec![
        (
            support::write_gltf_with_required_extension(dir.path(), "EXT_mesh_gpu_instancing"),
            "EXT_mesh_gpu_instancing",
        ),
        (support::write_gltf_with_nan_position(dir.path()), "non-finite"),
        (support::write_gltf_missing_bin(dir.path()), "missing.bin"),
        (support::write_gltf_with_bad_index(dir.path()), "index"),
        (support::write_gltf_with_bmp_texture(dir.path()), "image format"),
        (
            support::write_gltf_with_translation(dir.path(), [1e38, 0.0, 0.0]),
            "translated.gltf: node 0: ",
        ),
        (dir.path().join("does-not-exist.gltf"), "does-not-exist.gltf"),
        (
            PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/traces/floor.strace")),
            "this is a shadetrace trace, not a glTF file",
        ),
    ];
    for (input, needle) in cases {
        let o = shadetrace(&["capture", input.to_str().unwrap(), "-o", out.to_str().unwrap()]);
        assert_clean_failure(&o, needle, Some(&out));
    }
}

#[test]
fn bad_options_fail_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.strace");
    let o = out.to_str().unwrap();
    for (args, needle) in [
        (vec!["capture", "builtin:teapot", "-o", o], "teapot"),
        (vec!["capture", "builtin:floor", "-o", o, "--frames", "0"], "--frames"),
        (vec!["capture", "builtin:floor", "-o", o, "--res", "0x10"], "--res"),
        (
            vec!["capture", "builtin:floor", "-o", o, "--ipd", "-1"],
            "--ipd -1 must be",
        ),
        (vec!["capture", "builtin:floor", "-o", o, "--near", "-0.5"], "--near"),
        (vec!["capture", "builtin:floor", "-o", o, "--path", "spiral"], "spiral"),
        (
            vec!["capture", "builtin:floor", "-o", o, "--path", "camera:3"],
            "camera",
        ),
        (
            vec!["capture", "builtin:floor", "-o", "/nonexistent-dir/x.strace"],
            "nonexistent-dir",
        ),
    ] {
        assert_clean_failure(&shadetrace(&args), needle, Some(&out));
    }
}

#[test]
fn bad_traces_fail_cleanly_in_info() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("good.strace");
    capture_and_info("builtin:floor", &good, &[]);
    let bytes = std::fs::read(&good).unwrap();
    let write = |name: &str, data: &[u8]| {
        let p = dir.path().join(name);
        std::fs::write(&p, data).unwrap();
        p
    };
    let mut newer = bytes.clone();
    newer[4] = 9;
    let mut flipped = bytes.clone();
    let mid = bytes.len() / 2;
    flipped[mid] ^= 0x55;
    let cases = [
        (write("truncated.strace", &bytes[..bytes.len() - 7]), "truncated"),
        (
            write("magic.strace", b"GLTF\x01\x00\x00\x00\x00\x00\x00\x00"),
            "not a shadetrace trace",
        ),
        (write("newer.strace", &newer), "newer"),
        (write("empty.strace", b""), "truncated"),
        (write("flipped.strace", &flipped), "flipped.strace"),
        (dir.path().join("missing.strace"), "missing.strace"),
    ];
    for (path, needle) in cases {
        let o = shadetrace(&["info", path.to_str().unwrap()]);
        assert_clean_failure(&o, needle, None);
        assert!(
            stderr(&o).contains(path.file_name().unwrap().to_str().unwrap()),
            "error must name the file"
        );
    }
}

/// Runs the binary to completion and returns its output and peak resident memory in KiB
/// (from `wait4`, so it is this child's own peak, whatever else the test process runs).
/// A run longer than 60 s is killed and fails the test: a FIFO must not block forever.
#[cfg(target_os = "linux")]
fn shadetrace_measured(args: &[&str]) -> (Output, u64) {
    use std::io::Read;
    use std::process::Stdio;
    // The child is reaped by wait4 below, which std's `wait` cannot give the usage of.
    #[allow(clippy::zombie_processes)]
    let mut child = Command::new(env!("CARGO_BIN_EXE_shadetrace"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let pid = child.id() as libc::pid_t;
    let (mut out, mut err) = (child.stdout.take().unwrap(), child.stderr.take().unwrap());
    let readers = (
        std::thread::spawn(move || {
            let mut b = Vec::new();
            out.read_to_end(&mut b).map(|_| b)
        }),
        std::thread::spawn(move || {
            let mut b = Vec::new();
            err.read_to_end(&mut b).map(|_| b)
        }),
    );
    let started = std::time::Instant::now();
    let (mut status, mut usage) = (0, unsafe { std::mem::zeroed::<libc::rusage>() });
    loop {
        // SAFETY: wait4 on our own child; status and usage are valid out-pointers.
        let done = unsafe { libc::wait4(pid, &mut status, libc::WNOHANG, &mut usage) };
        assert!(done >= 0, "wait4 failed");
        if done == pid {
            break;
        }
        if started.elapsed() > std::time::Duration::from_secs(60) {
            child.kill().unwrap();
            let _ = child.wait();
            panic!("shadetrace {args:?} still running after 60 s");
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    let output = Output {
        status: std::os::unix::process::ExitStatusExt::from_raw(status),
        stdout: readers.0.join().unwrap().unwrap(),
        stderr: readers.1.join().unwrap().unwrap(),
    };
    (output, usage.ru_maxrss as u64)
}

/// Peak memory allowed on a hostile input (the README's promise).
#[cfg(target_os = "linux")]
const HOSTILE_INPUT_RSS_KIB: u64 = 256 << 10;

/// A zstd frame of `len` zeros, compressed as it is generated.
fn zeros_frame(len: u64) -> Vec<u8> {
    use std::io::Write;
    let mut encoder = zstd::stream::Encoder::new(Vec::new(), 1).unwrap();
    encoder.set_pledged_src_size(Some(len)).unwrap();
    let block = vec![0u8; 1 << 20];
    for _ in 0..len >> 20 {
        encoder.write_all(&block).unwrap();
    }
    encoder.finish().unwrap()
}

/// The chunks of a trace file as (kind, header+payload bytes), End excluded.
fn split_chunks(bytes: &[u8]) -> Vec<(u32, Vec<u8>)> {
    let mut chunks = Vec::new();
    let mut at = 12;
    while at < bytes.len() - 52 {
        let word = |o: usize, n: usize| {
            u64::from_le_bytes(
                bytes[o..o + n]
                    .iter()
                    .chain([0u8; 8].iter())
                    .take(8)
                    .copied()
                    .collect::<Vec<_>>()
                    .try_into()
                    .unwrap(),
            )
        };
        let (kind, packed) = (word(at, 4) as u32, word(at + 12, 8) as usize);
        chunks.push((kind, bytes[at..at + 20 + packed].to_vec()));
        at += 20 + packed;
    }
    chunks
}

fn chunk(kind: u32, raw_len: u64, packed: &[u8]) -> Vec<u8> {
    let mut c = kind.to_le_bytes().to_vec();
    c.extend_from_slice(&raw_len.to_le_bytes());
    c.extend_from_slice(&(packed.len() as u64).to_le_bytes());
    c.extend_from_slice(packed);
    c
}

#[test]
#[cfg(target_os = "linux")]
fn decompression_bombs_are_refused_in_bounded_memory() {
    let dir = tempfile::tempdir().unwrap();
    let good = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/traces/floor.strace")).unwrap();
    let (head, end) = (&good[..12], &good[good.len() - 52..]);
    let chunks = split_chunks(&good);
    let gib = zeros_frame(1 << 30);
    let build = |name: &str, chunks: &[Vec<u8>]| {
        let mut bytes = head.to_vec();
        chunks.iter().for_each(|c| bytes.extend_from_slice(c));
        bytes.extend_from_slice(end);
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        path
    };
    let plain: Vec<Vec<u8>> = chunks.iter().map(|(_, c)| c.clone()).collect();
    let mut unknown = plain.clone();
    unknown.insert(5, chunk(0x77, 1 << 30, &gib));
    let textures: Vec<Vec<u8>> = chunks
        .iter()
        .map(|(kind, c)| if *kind == 4 { chunk(4, 1 << 30, &gib) } else { c.clone() })
        .collect();
    let mut three = plain.clone();
    for kind in [0x70, 0x71, 0x72] {
        three.insert(5, chunk(kind, 1 << 30, &gib));
    }
    for (path, needle) in [
        (build("unknown.strace", &unknown), "Unknown(0x77) chunk"),
        (build("textures.strace", &textures), "Textures chunk"),
        (build("three.strace", &three), "decompression bomb"),
    ] {
        let p = path.to_str().unwrap();
        assert!(std::fs::metadata(&path).unwrap().len() < 1 << 20, "a small file");
        let out = dir.path().join("out");
        for args in [
            vec!["info", p],
            vec!["replay", p, "--out", out.to_str().unwrap(), "--res", "32x36"],
        ] {
            let (o, rss_kib) = shadetrace_measured(&args);
            assert_clean_failure(&o, needle, None);
            assert!(
                stderr(&o).contains(path.file_name().unwrap().to_str().unwrap()),
                "names the file"
            );
            assert!(rss_kib < HOSTILE_INPUT_RSS_KIB, "{args:?}: peak RSS {rss_kib} KiB");
        }
    }
}

#[test]
#[cfg(target_os = "linux")]
fn gltf_files_outside_the_model_folder_devices_and_fifos_are_never_read() {
    let outer = tempfile::tempdir().unwrap();
    let dir = outer.path().join("model");
    std::fs::create_dir(&dir).unwrap();
    // A file beside the model's folder that would import fine if it were read.
    std::fs::write(outer.path().join("secret.bin"), support::triangle_buffer()).unwrap();
    std::os::unix::fs::symlink("/dev/zero", dir.join("zero.bin")).unwrap();
    std::os::unix::fs::symlink("../secret.bin", dir.join("link.bin")).unwrap();
    let fifo = dir.join("fifo.bin");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    std::fs::create_dir(dir.join("sub.bin")).unwrap();
    let out = outer.path().join("out.strace");
    for (uri, needle) in [
        ("/etc/passwd", "outside the model's folder"),
        ("../secret.bin", "outside the model's folder"),
        ("sub.bin/../../secret.bin", "outside the model's folder"),
        ("sub.bin/../inside/../../secret.bin", "outside the model's folder"),
        ("/dev/zero", "outside the model's folder"),
        ("zero.bin", "outside the model's folder"),
        ("link.bin", "outside the model's folder"),
        ("fifo.bin", "not a regular file"),
        ("sub.bin", "not a regular file"),
    ] {
        let gltf = support::write_gltf_with_buffer_uri(&dir, uri);
        let (o, rss_kib) = shadetrace_measured(&["capture", gltf.to_str().unwrap(), "-o", out.to_str().unwrap()]);
        assert_clean_failure(&o, needle, Some(&out));
        assert!(stderr(&o).contains("buffer 0"), "names the buffer: {}", stderr(&o));
        assert!(rss_kib < HOSTILE_INPUT_RSS_KIB, "{uri}: peak RSS {rss_kib} KiB");
    }
    // The same bytes inside the folder import.
    std::fs::write(dir.join("inside.bin"), support::triangle_buffer()).unwrap();
    let gltf = support::write_gltf_with_buffer_uri(&dir, "inside.bin");
    let o = shadetrace(&[
        "capture",
        gltf.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
#[cfg(target_os = "linux")]
fn an_image_bomb_is_refused_from_its_header() {
    let dir = tempfile::tempdir().unwrap();
    // 16000 x 16000 grey, a few hundred KB as PNG: 1 GB as RGBA.
    let mut png = Vec::new();
    let encoder = image::codecs::png::PngEncoder::new_with_quality(
        &mut png,
        image::codecs::png::CompressionType::Fast,
        image::codecs::png::FilterType::NoFilter,
    );
    image::ImageEncoder::write_image(
        encoder,
        &vec![0u8; 16000 * 16000],
        16000,
        16000,
        image::ExtendedColorType::L8,
    )
    .unwrap();
    std::fs::write(dir.path().join("big.png"), &png).unwrap();
    let gltf = support::write_gltf_with_image_uri(dir.path(), "big.png");
    let out = dir.path().join("out.strace");
    let (o, rss_kib) = shadetrace_measured(&["capture", gltf.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_clean_failure(&o, "16000x16000", Some(&out));
    assert!(rss_kib < HOSTILE_INPUT_RSS_KIB, "peak RSS {rss_kib} KiB");
}

#[test]
fn a_replay_never_leaves_results_beside_another_runs_pictures() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    std::fs::create_dir(&out).unwrap();
    let trace = concat!(env!("CARGO_MANIFEST_DIR"), "/traces/floor.strace");
    // What an earlier run left: its results, a frame this run will not write, a user's
    // file, and a temporary of a process killed mid-write on this host.
    std::fs::write(out.join("results.json"), "{}").unwrap();
    std::fs::write(out.join("frame0007-left.png"), "old").unwrap();
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    let stale = out.join(format!(
        "{}x.png.tmp",
        shadetrace_formats::atomic_file::temporary_prefix(999_999_999)
    ));
    std::fs::write(&stale, "half a png").unwrap();
    let replay = |extra: &[&str]| {
        let mut args = vec![
            "replay",
            trace,
            "--frames",
            "0",
            "--res",
            "32x36",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        shadetrace(&args)
    };
    let o = replay(&["--quiet"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("removed 1 temporary file(s)"), "{}", stderr(&o));
    assert!(!stale.exists() && !out.join("frame0007-left.png").exists());
    assert!(
        out.join("notes.txt").exists(),
        "files that are not a run's outputs stay"
    );
    let results: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    assert_eq!(results["frames"].as_array().unwrap().len(), 1);

    // A run that fails while writing its pictures leaves no results.json at all.
    std::fs::remove_file(out.join("frame0000-stereo.png")).unwrap();
    std::fs::create_dir(out.join("frame0000-stereo.png")).unwrap();
    let o = replay(&["--quiet"]);
    assert!(!o.status.success());
    assert!(
        !out.join("results.json").exists(),
        "an old results.json beside new pictures"
    );
}

#[test]
fn check_outside_a_corpus_says_how_to_name_one() {
    let dir = tempfile::tempdir().unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_shadetrace"))
        .arg("check")
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert_clean_failure(&o, "--traces DIR", None);
}

/// Maps that sample other UVs than base colour (here: without its texture transform) are
/// named in one warning.
#[test]
fn texture_maps_that_are_not_captured_are_named_in_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let gltf = support::write_textured_gltf(dir.path());
    let mut doc: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&gltf).unwrap()).unwrap();
    doc["materials"][0]["normalTexture"] = serde_json::json!({ "index": 0 });
    doc["materials"][0]["emissiveTexture"] = serde_json::json!({ "index": 0 });
    doc["materials"][0]["emissiveFactor"] = serde_json::json!([1.0, 1.0, 1.0]);
    std::fs::write(&gltf, doc.to_string()).unwrap();
    let out = dir.path().join("out.strace");
    let o = shadetrace(&[
        "capture",
        gltf.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--res",
        "32x36",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let warning = stderr(&o);
    assert!(
        warning.contains("material 0")
            && warning.contains("normal (its UVs")
            && warning.contains("emissive (its UVs")
            && warning.contains("ignored"),
        "{warning}"
    );
}

#[test]
fn the_compare_table_fits_100_columns() {
    let dir = tempfile::tempdir().unwrap();
    let trace = concat!(env!("CARGO_MANIFEST_DIR"), "/traces/spheres.strace");
    let out = dir.path().join("cmp");
    let o = shadetrace(&[
        "compare",
        trace,
        "--res",
        "32x36",
        "--frames",
        "0",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let table = stdout(&o);
    assert!(table.lines().any(|l| l.starts_with("preset ")), "{table}");
    for line in table.lines() {
        assert!(line.chars().count() <= 100, "{} columns: {line}", line.chars().count());
    }
}

/// A Draco stream the decoder panics on (see capture's `compressed` tests): one `error:`
/// line naming the file, no panic message, no trace.
#[test]
fn corrupt_draco_gives_one_line_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let fixture = Path::new(env!("CARGO_MANIFEST_DIR")).join("capture/tests/fixtures/wavy_grid-draco.glb");
    let mut glb = std::fs::read(fixture).unwrap();
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    glb[20 + json_len + 8 + 168 + 1661] = 0xff;
    let input = dir.path().join("corrupt.glb");
    std::fs::write(&input, &glb).unwrap();
    let out = dir.path().join("corrupt.strace");
    let o = shadetrace(&["capture", input.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_clean_failure(&o, "corrupt Draco data", Some(&out));
}

/// Output piped into a reader that has already closed (`shadetrace presets | head -0`) ends
/// the process by SIGPIPE, as it ends any Unix tool, not in a panic.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
#[test]
fn a_closed_output_pipe_ends_quietly() {
    use std::os::unix::process::ExitStatusExt;
    use std::process::Stdio;
    let mut child = Command::new(env!("CARGO_BIN_EXE_shadetrace"))
        .arg("presets")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // The reader closes before the process has written anything.
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    assert!(!stderr(&out).contains("panicked"), "{}", stderr(&out));
    assert_eq!(out.status.signal(), Some(libc::SIGPIPE), "{:?}", out.status);
}
