//! `shadetrace info`: what a trace holds and how well it compresses.

use std::fs::File;
use std::io::BufReader;
use std::path::PathBuf;

use shadetrace_formats::{ChunkKind, Source, TraceReader};

#[derive(clap::Args)]
pub struct Args {
    /// Trace file.
    trace: PathBuf,
    /// Skip decompressing every chunk to check the content hash.
    #[arg(long)]
    no_verify: bool,
}

pub fn run(args: Args) -> Result<(), String> {
    let path = args.trace.display().to_string();
    let fail = |e: shadetrace_formats::Error| format!("{path}: {e}");
    let file = File::open(&args.trace).map_err(|e| format!("{path}: {e}"))?;
    let mut reader = TraceReader::open(BufReader::new(file)).map_err(fail)?;
    let verified = if args.no_verify {
        "not verified"
    } else {
        reader.verify().map_err(fail)?;
        "verified"
    };
    let meta = reader.meta().clone();
    let (major, minor) = reader.version();
    let c = &meta.counts;
    let s = &meta.capture;
    println!("trace        {path}");
    println!(
        "format       {major}.{minor}, written by shadetrace-capture {}",
        meta.tool_version
    );
    println!("content hash {} ({verified})", reader.content_hash());
    println!("scene        {}", meta.scene_name);
    match &meta.source {
        Source::Builtin { name, params } if params.is_empty() => println!("source       builtin:{name}"),
        Source::Builtin { name, params } => println!("source       builtin:{name}?{params}"),
        Source::File { file_name, sha256 } => println!(
            "source       {file_name} (sha256 {})",
            sha256.iter().map(|b| format!("{b:02x}")).collect::<String>()
        ),
    }
    println!(
        "capture      {} frames, path {}, {}x{} per eye, IPD {} mm, textures <= {}, {} fps",
        s.frames,
        s.camera_path,
        s.eye_width,
        s.eye_height,
        s.ipd_m * 1000.0,
        s.max_texture,
        s.fps
    );
    println!("features     {}", meta.features);
    println!(
        "counts       {} meshes, {} triangles, {} vertices, {} materials, {} textures, {} lights",
        c.meshes, c.triangles, c.vertices, c.materials, c.textures, c.lights
    );
    if c.rigid_slots > 0 || !c.skinned_slots.is_empty() {
        println!(
            "motion       {} rigid node(s), {} skinned mesh(es)",
            c.rigid_slots,
            c.skinned_slots.len()
        );
    }
    if !meta.bounds.is_empty() {
        let (lo, hi) = (meta.bounds.min, meta.bounds.max);
        println!(
            "bounds       [{:.3}, {:.3}, {:.3}] .. [{:.3}, {:.3}, {:.3}]",
            lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
        );
    }
    println!();
    println!(
        "{:<10} {:>6} {:>14} {:>14} {:>7}",
        "chunk", "count", "raw bytes", "packed bytes", "ratio"
    );
    let kinds = [
        ChunkKind::Meta,
        ChunkKind::Geometry,
        ChunkKind::Materials,
        ChunkKind::Textures,
        ChunkKind::Lights,
        ChunkKind::SurfaceMaps,
        ChunkKind::Frame,
    ];
    let mut unknown: Vec<ChunkKind> = reader
        .chunks()
        .iter()
        .map(|c| c.kind)
        .filter(|k| matches!(k, ChunkKind::Unknown(_)))
        .collect();
    unknown.dedup();
    let (mut raw_total, mut packed_total) = (0u64, 0u64);
    for kind in kinds.into_iter().chain(unknown) {
        let chunks: Vec<_> = reader.chunks().iter().filter(|c| c.kind == kind).collect();
        if chunks.is_empty() && kind == ChunkKind::SurfaceMaps {
            continue; // optional: most traces have none
        }
        let raw: u64 = chunks.iter().map(|c| c.raw_len).sum();
        let packed: u64 = chunks.iter().map(|c| c.packed_len).sum();
        raw_total += raw;
        packed_total += packed;
        println!(
            "{:<10} {:>6} {:>14} {:>14} {:>6.2}x",
            kind.to_string(),
            chunks.len(),
            raw,
            packed,
            raw as f64 / packed.max(1) as f64
        );
    }
    println!(
        "{:<10} {:>6} {:>14} {:>14} {:>6.2}x",
        "total",
        reader.chunks().len(),
        raw_total,
        packed_total,
        raw_total as f64 / packed_total.max(1) as f64
    );
    println!();
    println!("file size    {} bytes", reader.file_len());
    if c.triangles > 0 {
        let geometry_packed: u64 = reader
            .chunks()
            .iter()
            .filter(|c| c.kind == ChunkKind::Geometry)
            .map(|c| c.packed_len)
            .sum();
        println!(
            "per triangle {:.2} bytes (file), {:.2} bytes (geometry chunk)",
            reader.file_len() as f64 / c.triangles as f64,
            geometry_packed as f64 / c.triangles as f64
        );
    }
    Ok(())
}
