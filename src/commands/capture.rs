//! `shadetrace capture`: scene to trace.

use std::path::PathBuf;

use shadetrace_capture::{capture, CameraPathSpec, CaptureOptions, ImportLimits, Input};
use shadetrace_formats::DEFAULT_ZSTD_LEVEL;

use crate::progress;
use shadetrace_formats::atomic_file::write_atomically;

#[derive(clap::Args)]
pub struct Args {
    /// A .gltf/.glb file, or builtin:NAME (floor, spheres, hairball, depth-stack, light-room;
    /// builtin:spheres?subdiv=N for one tessellation level).
    input: String,
    /// Output trace file (.strace).
    #[arg(short, long)]
    output: PathBuf,
    /// Number of frames.
    #[arg(long, default_value_t = 1)]
    frames: u32,
    /// Camera path: orbit, walk (inside the bounds at eye height), camera, camera:N (glTF
    /// camera N) or a flythrough .toml file.
    #[arg(long, default_value = "orbit")]
    path: String,
    /// Interpupillary distance in metres (0.07 = 70 mm, as in the tile-pair paper).
    #[arg(long, default_value_t = 0.07, allow_negative_numbers = true)]
    ipd: f32,
    /// Per-eye resolution WIDTHxHEIGHT.
    #[arg(long, default_value = "1280x1440", value_parser = shadetrace_replay::options::parse_resolution)]
    res: (u32, u32),
    /// Vertical field of view in degrees (default: the camera's, the flythrough's, or 90).
    #[arg(long, allow_negative_numbers = true)]
    fov: Option<f32>,
    /// Zero-parallax distance of the off-axis frusta, metres.
    #[arg(long, default_value_t = 2.0, allow_negative_numbers = true)]
    convergence: f32,
    /// Near plane in metres (default: the camera's znear or 0.05).
    #[arg(long, allow_negative_numbers = true)]
    near: Option<f32>,
    /// Largest texture edge kept; larger textures are filtered down.
    #[arg(long, default_value_t = 1024)]
    max_texture: u32,
    /// Frames per second for sampling animation.
    #[arg(long, default_value_t = 30.0, allow_negative_numbers = true)]
    fps: f32,
    /// zstd compression level (does not change the content hash).
    #[arg(long, default_value_t = DEFAULT_ZSTD_LEVEL, value_parser = clap::value_parser!(i32).range(1..=22))]
    zstd_level: i32,
    /// No progress bar, no summary.
    #[arg(short, long)]
    quiet: bool,
}

pub fn run(args: Args) -> Result<(), String> {
    let options = CaptureOptions {
        frames: args.frames,
        path: CameraPathSpec::parse(&args.path).map_err(|e| e.to_string())?,
        ipd_m: args.ipd,
        eye_width: args.res.0,
        eye_height: args.res.1,
        yfov_deg: args.fov,
        convergence_m: args.convergence,
        near_m: args.near,
        max_texture: args.max_texture,
        fps: args.fps,
        import_limits: ImportLimits::DEFAULT,
    };
    let input = Input::parse(&args.input);
    let bar = progress::bar(args.frames as u64, "frames", args.quiet);
    let captured =
        capture(&input, &options, &mut |done, _| bar.set_position(done as u64)).map_err(|e| e.to_string())?;
    bar.finish_and_clear();
    for warning in &captured.warnings {
        eprintln!("warning: {warning}");
    }
    let (bytes, hash) = write_atomically(&args.output, |out| {
        let (counter, hash) = captured
            .write(CountingWriter::new(out), args.zstd_level)
            .map_err(|e| format!("{}: {e}", args.output.display()))?;
        Ok((counter.written, hash))
    })?;
    if !args.quiet {
        let counts = &captured.meta.counts;
        println!(
            "{}: {} frames, {} triangles, {} bytes ({:.1} bytes/triangle), features: {}",
            args.output.display(),
            counts.frames,
            counts.triangles,
            bytes,
            bytes as f64 / counts.triangles.max(1) as f64,
            captured.meta.features
        );
        println!("content hash {hash}");
    }
    Ok(())
}

/// Counts bytes on their way to the file (for the summary line).
struct CountingWriter<W> {
    inner: W,
    written: u64,
}

impl<W> CountingWriter<W> {
    fn new(inner: W) -> Self {
        CountingWriter { inner, written: 0 }
    }
}

impl<W: std::io::Write> std::io::Write for CountingWriter<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.written += n as u64;
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}
