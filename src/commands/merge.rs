//! `shadetrace merge STORES... -o DIR`: combines the stores of a sweep's shards into
//! DIR/sweep.db (and DIR/frames.csv). Idempotent: merging a store twice adds nothing; stores
//! of different specs are refused.

use std::path::PathBuf;

use crate::sweep::store::Store;

#[derive(clap::Args)]
pub struct Args {
    /// Shard stores (shard-I-of-N.db) of one sweep.
    #[arg(required = true)]
    stores: Vec<PathBuf>,
    /// Folder of the merged store.
    #[arg(short, long)]
    out: PathBuf,
    #[arg(short, long)]
    quiet: bool,
}

pub fn run(args: Args) -> Result<(), String> {
    let first = Store::open_existing(&args.stores[0])?;
    let spec_hash = first.spec_hash()?.unwrap_or_default();
    drop(first);
    // Refuse a mix before writing anything.
    for path in &args.stores[1..] {
        if Store::open_existing(path)?.spec_hash()?.as_deref() != Some(spec_hash.as_str()) {
            return Err(format!(
                "{}: written for another spec than {}",
                path.display(),
                args.stores[0].display()
            ));
        }
    }
    std::fs::create_dir_all(&args.out).map_err(|e| format!("{}: {e}", args.out.display()))?;
    let path = args.out.join("sweep.db");
    let mut merged = Store::open(&path, &spec_hash)?;
    let mut added = 0;
    for store in &args.stores {
        added += merged.merge_from(store)?;
    }
    merged.export_csv(&args.out.join("frames.csv"))?;
    if !args.quiet {
        println!(
            "merged {} stores into {}: {added} jobs added, {} in all",
            args.stores.len(),
            path.display(),
            merged.job_count()?
        );
    }
    Ok(())
}
