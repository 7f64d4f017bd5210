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
