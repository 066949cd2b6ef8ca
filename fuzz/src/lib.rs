//! The fuzz harnesses, one function per input kind; the `fuzz_targets/` binaries only hand
//! libFuzzer's bytes to them. Each checks more than "no panic": what a reader accepts must
//! survive a round trip through the writer, and what capture accepts must be a trace the
//! reader accepts.

use std::io::Cursor;
use std::path::PathBuf;
use std::sync::OnceLock;

use shadetrace_capture::{capture, CaptureOptions, Flythrough, ImportLimits, Input};
use shadetrace_formats::{TraceReader, TraceWriter};

/// Frames decoded per trace at most, so one input cannot run for long.
const MAX_FRAMES: u32 = 8;

/// Reads a trace like `info` and `replay` do; if every part is accepted, writing it back and
/// reading it again gives the same content hash and the same data.
pub fn trace_reader(data: &[u8]) {
    let Ok(mut reader) = TraceReader::open(Cursor::new(data)) else {
        return;
    };
    let Ok(scene) = reader.scene() else { return };
    let frames: Vec<_> = (0..reader.frame_count().min(MAX_FRAMES))
        .map(|i| reader.frame(i))
        .collect();
    let Ok(frames) = frames.into_iter().collect::<Result<Vec<_>, _>>() else {
        return;
    };
    let Ok(hash) = reader.verify() else { return };
    if reader.frame_count() > MAX_FRAMES
        || reader
            .chunks()
            .iter()
            .any(|c| matches!(c.kind, shadetrace_formats::ChunkKind::Unknown(_)))
    {
        return; // not re-writable as is: frames left out, or chunks this writer does not write
    }
    let meta = reader.meta().clone();
    let mut writer = TraceWriter::new(Vec::new(), 1, &meta, &scene).expect("an accepted trace re-encodes");
    for frame in &frames {
        writer.write_frame(frame).expect("an accepted frame re-encodes");
    }
    let (bytes, rewritten) = writer.finish().expect("finish");
    assert_eq!(rewritten, hash, "the content hash survives a round trip");
    let mut again = TraceReader::open(Cursor::new(&bytes)).expect("a re-written trace opens");
    assert_eq!(again.scene().expect("scene"), scene);
}

/// A private folder holding the files the glTF seeds refer to (`quad.bin`, `checker.png`).
fn model_folder() -> &'static PathBuf {
    static FOLDER: OnceLock<PathBuf> = OnceLock::new();
    FOLDER.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("shadetrace-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("fuzz folder");
        // This file is built by the fuzz crate and, through `#[path]`, by the main
        // package's regression test: its seeds are in `seeds/` or `fuzz/seeds/`.
        let manifest = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let seeds = [manifest.join("seeds/files"), manifest.join("fuzz/seeds/files")]
            .into_iter()
            .find(|d| d.is_dir())
            .expect("fuzz/seeds/files");
        for entry in std::fs::read_dir(seeds).expect("seed files").flatten() {
            std::fs::copy(entry.path(), dir.join(entry.file_name())).expect("copy seed file");
        }
        dir
    })
}

/// What one fuzzed import may decode: far below the run's 512 MiB of RSS, so that memory
/// which escapes the import's budget (a count a few bytes declare, decoded unchecked) is
/// what reaches that limit and is reported.
const FUZZ_LIMITS: ImportLimits = ImportLimits {
    geometry_bytes: 16 << 20,
    image_bytes: 8 << 20,
};

/// Captures the bytes as a `.gltf`/`.glb` file (two small frames); whatever capture accepts
/// must write a trace the reader accepts with the same hash.
pub fn gltf_import(data: &[u8]) {
    // libFuzzer's panic hook aborts on every panic; capture contains a decoder's panics on
    // corrupt input and reports them as errors, as the binary does, so those are not
    // findings: the hook hears only the others.
    shadetrace_capture::contained::quiet_contained_panics();
    let path = model_folder().join("input.glb");
    std::fs::write(&path, data).expect("write input");
    let opts = CaptureOptions {
        frames: 2,
        eye_width: 16,
        eye_height: 16,
        max_texture: 16,
        import_limits: FUZZ_LIMITS,
        ..CaptureOptions::default()
    };
    let Ok(captured) = capture(&Input::File(path), &opts, &mut |_, _| {}) else {
        return;
    };
    let (bytes, hash) = captured
        .write(Vec::new(), 1)
        .expect("an accepted capture writes a trace");
    let mut reader = TraceReader::open(Cursor::new(&bytes)).expect("a captured trace opens");
    assert_eq!(reader.verify().expect("a captured trace verifies"), hash);
}

/// Parses a flythrough; an accepted one gives a pose at its start, middle and end.
pub fn flythrough(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok(fly) = Flythrough::parse(text) else { return };
    for t in [
        fly.start_time(),
        fly.start_time() + fly.duration() / 2.0,
        fly.start_time() + fly.duration(),
    ] {
        let _ = fly.pose_at(t);
    }
}
