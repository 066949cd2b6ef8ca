//! The one way shadetrace writes an output file: into a temporary file beside the target,
//! flushed to disk and renamed into place, so a failed, killed or out-of-space command never
//! leaves a half-written file where a finished one is expected.
//!
//! Temporaries are named `.shadetrace-HOST-PID-RANDOM.tmp`. A process killed mid-write
//! (SIGKILL skips every destructor) leaves its temporary behind; the next write into the
//! same directory on the same host removes those whose process is gone. Temporaries of
//! other hosts (a shared file system) and of live processes are left alone.

use std::collections::BTreeSet;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

const PREFIX: &str = ".shadetrace-";
const SUFFIX: &str = ".tmp";

/// Creates `path` atomically from what `fill` writes; on error nothing is left behind.
pub fn write_atomically<T>(
    path: &Path,
    fill: impl FnOnce(&mut BufWriter<&mut std::fs::File>) -> Result<T, String>,
) -> Result<T, String> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    sweep_once(dir);
    let mut builder = tempfile::Builder::new();
    let prefix = temporary_prefix(std::process::id());
    builder.prefix(&prefix).suffix(SUFFIX);
    // Temporary files are private (0600); the finished output is an ordinary file.
    #[cfg(unix)]
    builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o644));
    let mut tmp = builder
        .tempfile_in(dir)
        .map_err(|e| format!("{}: cannot create a file in {}: {e}", path.display(), dir.display()))?;
    let value = {
        let mut out = BufWriter::new(tmp.as_file_mut());
        let value = fill(&mut out)?;
        out.flush().map_err(|e| format!("{}: {e}", path.display()))?;
        value
    };
    tmp.as_file()
        .sync_all()
        .map_err(|e| format!("{}: {e}", path.display()))?;
    tmp.persist(path)
        .map_err(|e| format!("{}: {}", path.display(), e.error))?;
    Ok(value)
}

/// Writes `bytes` to `path` atomically.
pub fn write_bytes_atomically(path: &Path, bytes: &[u8]) -> Result<(), String> {
    write_atomically(path, |w| {
        w.write_all(bytes).map_err(|e| format!("{}: {e}", path.display()))
    })
}

/// How the temporaries of process `pid` on this host begin (they end in `.tmp`).
pub fn temporary_prefix(pid: u32) -> String {
    format!("{PREFIX}{}-{pid}-", host())
}

/// Sweeps each directory at most once per process.
fn sweep_once(dir: &Path) {
    static SWEPT: Mutex<BTreeSet<PathBuf>> = Mutex::new(BTreeSet::new());
    let first = SWEPT
        .lock()
        .map(|mut swept| swept.insert(dir.to_path_buf()))
        .unwrap_or(false);
    if first {
        let removed = remove_stale_temporaries(dir);
        if removed > 0 {
            eprintln!(
                "note: removed {removed} temporary file(s) in {} left by killed shadetrace runs",
                dir.display()
            );
        }
    }
}

/// Removes this host's temporaries in `dir` whose process no longer runs; returns how many.
pub fn remove_stale_temporaries(dir: &Path) -> usize {
    let Ok(entries) = std::fs::read_dir(dir) else { return 0 };
    let ours = format!("{PREFIX}{}-", host());
    entries
        .filter_map(|e| e.ok())
        .filter(|e| {
            let name = e.file_name();
            let Some(rest) = name.to_str().and_then(|n| n.strip_prefix(&ours)) else {
                return false;
            };
            let pid = rest.split('-').next().and_then(|p| p.parse::<u32>().ok());
            name.to_str().is_some_and(|n| n.ends_with(SUFFIX)) && pid.is_some_and(|pid| !process_alive(pid))
        })
        .filter(|e| std::fs::remove_file(e.path()).is_ok())
        .count()
}

/// The host name, with `-` and anything but letters and digits replaced, so that it cannot
/// be confused with the fields after it.
fn host() -> String {
    let name = std::fs::read_to_string("/proc/sys/kernel/hostname").unwrap_or_default();
    let name: String = name
        .trim()
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if name.is_empty() {
        "host".to_string()
    } else {
        name
    }
}

/// Whether process `pid` exists on this host. Without `/proc`, every process counts as
/// alive, so nothing is removed.
fn process_alive(pid: u32) -> bool {
    if !Path::new("/proc/self").exists() {
        return true;
    }
    Path::new("/proc").join(pid.to_string()).exists()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failed_write_leaves_nothing_and_a_good_one_only_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.txt");
        let err = write_atomically(&path, |w| {
            w.write_all(b"half").unwrap();
            Err::<(), _>("disk full".to_string())
        });
        assert_eq!(err, Err("disk full".to_string()));
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        write_bytes_atomically(&path, b"done").unwrap();
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, ["out.txt"]);
        assert_eq!(std::fs::read(&path).unwrap(), b"done");
    }

    #[test]
    #[cfg(target_os = "linux")]
    fn temporaries_of_dead_processes_on_this_host_are_removed_others_kept() {
        let dir = tempfile::tempdir().unwrap();
        let me = std::process::id();
        // pid_max is at most 2^22 on Linux, so this process cannot exist.
        let dead = format!("{}abc{SUFFIX}", temporary_prefix(999_999_999));
        let live = format!("{}abc{SUFFIX}", temporary_prefix(me));
        let other_host = format!("{PREFIX}elsewhere0-999999999-abc{SUFFIX}");
        let not_ours = "results.json";
        for name in [&dead, &live, &other_host, &not_ours.to_string()] {
            std::fs::write(dir.path().join(name), b"x").unwrap();
        }
        assert_eq!(remove_stale_temporaries(dir.path()), 1);
        assert!(!dir.path().join(&dead).exists());
        for kept in [&live, &other_host, &not_ours.to_string()] {
            assert!(dir.path().join(kept).exists(), "{kept} must stay");
        }
    }
}
