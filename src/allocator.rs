//! Keeps freed memory in the process. Every frame allocates and frees the same few hundred
//! MiB (tile buffers, access logs, pictures); glibc's defaults hand large blocks back to the
//! kernel as soon as they are freed, so every frame faulted its memory in again (about
//! 400,000 page faults for a compare of four presets over three 1280x1440 frames).

/// Sets glibc's malloc to keep what it frees for the next frame: no trimming of the heap,
/// and mappings only for blocks above 32 MiB (the largest threshold glibc accepts). Peak
/// memory stays flat in frames (the same blocks are reused); other platforms' allocators
/// are left as they are.
pub fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only sets allocator parameters; it is called before any thread starts.
    unsafe {
        libc::mallopt(libc::M_TRIM_THRESHOLD, i32::MAX);
        libc::mallopt(libc::M_TOP_PAD, 64 << 20);
        libc::mallopt(libc::M_MMAP_THRESHOLD, 32 << 20);
    }
}
