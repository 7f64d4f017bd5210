//! Handing freed memory back to the operating system between the stages of a long run.
//!
//! glibc's allocator keeps what a thread freed in that thread's arena: the observation
//! records read on one thread and released while worker threads allocate the measurements
//! drawn from them would otherwise stay resident beside those measurements for the rest of
//! the run. Elsewhere (other C libraries, other systems) this does nothing.

/// Return the free pages of every allocator arena to the operating system.
pub fn release_freed() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only walks the allocator's own free lists; it takes no pointer and
    // is safe to call from any thread at any time.
    unsafe {
        libc::malloc_trim(0);
    }
}

/// Keep large buffers in the allocator's heap, to be reused, instead of mapping fresh pages
/// for each and unmapping them when freed: glibc maps every allocation above its threshold
/// (at most 32 MiB by default) on its own, and a photograph's scale-space levels (36 MB
/// each at 4000 × 2250, a dozen per photo) were each mapped, faulted in page by page, zeroed
/// and unmapped, with the other cores' address caches flushed each time: 30 % of feature
/// extraction in the kernel. Freed memory is still handed back by [`release_freed`].
/// Call once, early; elsewhere (other C libraries, other systems) this does nothing.
pub fn keep_large_buffers() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only sets an allocator parameter; it takes no pointer and is safe to
    // call from any thread at any time.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 1 << 30);
    }
}
