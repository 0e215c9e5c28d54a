//! The heap a build uses, measured rather than estimated: a counting global allocator that the
//! binary installs (`#[global_allocator]` in `crates/cli/src/main.rs`), switched on only around
//! a build.
//!
//! A structure's own `memory()` counts the arrays it keeps; what a build holds at its peak
//! (scratch arrays, per-pass copies, rayon's splits) is only known to the allocator. The
//! irregular-grid paper (Pérard-Gayot et al. 2017, §6.1) states its build's peak as a multiple
//! of the final memory (2.5-3x); [`measure`] gives both for every structure, as the rows'
//! `build_heap_peak_bytes` and `build_heap_kept_bytes`.
//!
//! The counter is one net byte count and its maximum, both relative to the start of the
//! measurement, updated with relaxed atomics only while a measurement is on (a relaxed load of
//! a flag otherwise). Blocks allocated before the start and freed during it make the net count
//! dip below zero, so the peak is the most the build held *above* what was live when it began.
//! Threads other than the build's (the progress bar) add their few bytes too; the figures are
//! exact for a one-thread build and within those few bytes for a parallel one.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicBool, AtomicIsize, Ordering::Relaxed};
use std::sync::{Mutex, OnceLock};

/// The system allocator with a net byte count while a [`measure`] runs.
pub struct CountingAlloc;

static ON: AtomicBool = AtomicBool::new(false);
static NET: AtomicIsize = AtomicIsize::new(0);
static PEAK: AtomicIsize = AtomicIsize::new(0);
/// One measurement at a time (the counters are global).
static ONE: Mutex<()> = Mutex::new(());

#[inline]
fn add(bytes: isize) {
    if ON.load(Relaxed) {
        let now = NET.fetch_add(bytes, Relaxed) + bytes;
        if now > PEAK.load(Relaxed) {
            PEAK.fetch_max(now, Relaxed);
        }
    }
}

// SAFETY: every call is forwarded to `System` with the caller's arguments; the counting
// touches only atomics and never allocates.
unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's contract for `alloc`, passed on.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            add(layout.size() as isize);
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's contract for `alloc_zeroed`, passed on.
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            add(layout.size() as isize);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: the caller's contract for `dealloc`, passed on.
        unsafe { System.dealloc(ptr, layout) };
        add(-(layout.size() as isize));
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: the caller's contract for `realloc`, passed on.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            add(new_size as isize - layout.size() as isize);
        }
        p
    }
}

/// What a measured call did to the heap, in bytes above what was live when it began.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HeapUse {
    /// The most the call held at once.
    pub peak: u64,
    /// What it still held when it returned (the structure it built).
    pub kept: u64,
}

/// Whether the running binary's global allocator is [`CountingAlloc`] (the `trace-bench`
/// binary's is; test binaries and embedders may use another, and then no figure is reported).
pub fn installed() -> bool {
    static INSTALLED: OnceLock<bool> = OnceLock::new();
    *INSTALLED.get_or_init(|| {
        let _one = ONE.lock().unwrap_or_else(|e| e.into_inner());
        NET.store(0, Relaxed);
        ON.store(true, Relaxed);
        let probe = std::hint::black_box(vec![0u8; 4096]);
        let moved = NET.load(Relaxed) != 0;
        ON.store(false, Relaxed);
        drop(probe);
        moved
    })
}

/// Run `f` with the heap counted: its result and, where [`CountingAlloc`] is installed, its
/// [`HeapUse`]. Measurements must not nest (another thread's waits for this one; one inside
/// `f` would wait forever).
pub fn measure<T>(f: impl FnOnce() -> T) -> (T, Option<HeapUse>) {
    if !installed() {
        return (f(), None);
    }
    let _one = ONE.lock().unwrap_or_else(|e| e.into_inner());
    NET.store(0, Relaxed);
    PEAK.store(0, Relaxed);
    ON.store(true, Relaxed);
    let out = f();
    ON.store(false, Relaxed);
    let used = HeapUse {
        peak: PEAK.load(Relaxed).max(0) as u64,
        kept: NET.load(Relaxed).max(0) as u64,
    };
    (out, Some(used))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The harness's unit-test binary keeps the system allocator: no figure, not a zero.
    #[test]
    fn without_the_counting_allocator_nothing_is_reported() {
        assert!(!installed());
        let (v, used) = measure(|| vec![0u8; 1 << 16]);
        assert_eq!(v.len(), 1 << 16);
        assert_eq!(used, None);
    }
}
