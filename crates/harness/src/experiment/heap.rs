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
//!
//! Large blocks are placed, not only counted ([`placement`], docs/variation.md): a block of
//! [`ALIGN_MIN`] bytes or more starts on a cache line whatever the allocator's history; with
//! `TRACE_BENCH_HUGEPAGES=1` a block of [`HUGE_MIN`] bytes or more starts on a 2 MiB boundary
//! and is marked for transparent huge pages (Linux `madvise(MADV_HUGEPAGE)`, which the
//! kernel's default `madvise` mode needs) before it is first touched.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicBool, AtomicIsize, AtomicU8, Ordering::Relaxed};
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

/// Blocks of at least this many bytes start on a cache line ([`LINE`]): node, triangle, ray
/// and hit arrays, whose elements (a 32-byte BVH node, a 64-byte treelet) would otherwise
/// straddle lines depending on where the allocator put them (glibc: 16 bytes into a page for
/// a block it maps, anywhere 16-aligned in its heaps, which the order of allocations of the
/// run's threads decides).
pub const ALIGN_MIN: usize = 4096;
/// A cache line.
pub const LINE: usize = 64;
/// Blocks of at least this many bytes are placed on huge pages where [`Placement::huge`].
pub const HUGE_MIN: usize = 2 << 20;
/// A transparent huge page on x86-64 and most aarch64 kernels.
const HUGE_ALIGN: usize = 2 << 20;
/// [`placement`]'s answer: 0 not yet read, else 1 + the `align` bit + 2 × the `huge` bit.
static PLACEMENT: AtomicU8 = AtomicU8::new(0);

/// Where large blocks go (docs/variation.md), read once from the environment on the first
/// large block and fixed for the process (a block's layout must be the same when it is freed).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Placement {
    /// Blocks of [`ALIGN_MIN`] bytes or more on a cache line: on unless
    /// `TRACE_BENCH_ALIGN=0` (for the variation study's A/B).
    pub align: bool,
    /// Blocks of [`HUGE_MIN`] bytes or more on 2 MiB boundaries, marked for transparent huge
    /// pages (`madvise(MADV_HUGEPAGE)`, Linux): with `TRACE_BENCH_HUGEPAGES=1` only (the
    /// variation study found the spread between processes no smaller overall: less for
    /// incoherent rays, more for primary rays, within its noise).
    pub huge: bool,
}

/// The process's [`Placement`].
pub fn placement() -> Placement {
    let mut p = PLACEMENT.load(Relaxed);
    if p == 0 {
        let align = env_flag(c"TRACE_BENCH_ALIGN").unwrap_or(true);
        let huge = cfg!(target_os = "linux") && env_flag(c"TRACE_BENCH_HUGEPAGES").unwrap_or(false);
        p = 1 + u8::from(align) + 2 * u8::from(huge);
        PLACEMENT.store(p, Relaxed);
    }
    Placement {
        align: (p - 1) & 1 != 0,
        huge: (p - 1) & 2 != 0,
    }
}

/// A variable set to `0` (false) or anything else (true); `None` when unset.
fn env_flag(name: &std::ffi::CStr) -> Option<bool> {
    #[cfg(unix)]
    {
        // SAFETY: `getenv` with a NUL-terminated name; it does not allocate (this runs inside
        // the allocator), and the binary never sets variables.
        let p = unsafe { libc::getenv(name.as_ptr()) };
        // SAFETY: a non-null `getenv` result is a NUL-terminated string.
        (!p.is_null()).then(|| unsafe { std::ffi::CStr::from_ptr(p) }.to_bytes() != b"0")
    }
    #[cfg(not(unix))]
    {
        let _ = name;
        None
    }
}

/// The layout a block of `layout` is allocated with (a larger alignment for a large block,
/// [`placement`]), and whether it goes on huge pages; `None`: the caller's layout.
fn placed(layout: Layout) -> Option<(Layout, bool)> {
    if layout.size() < ALIGN_MIN {
        return None;
    }
    let p = placement();
    let huge = p.huge && layout.size() >= HUGE_MIN;
    let align = if huge {
        HUGE_ALIGN
    } else if p.align {
        LINE
    } else {
        return None;
    };
    (align > layout.align())
        .then(|| Layout::from_size_align(layout.size(), align).ok())
        .flatten()
        .map(|l| (l, huge))
}

/// Mark the fresh block `p..p + size` (2 MiB-aligned) for huge pages.
fn advise(p: *mut u8, size: usize) {
    #[cfg(target_os = "linux")]
    // SAFETY: `p` starts a block of `size` bytes just allocated to us, on a page boundary;
    // the advice changes how its pages are backed, never their contents or ownership.
    unsafe {
        libc::madvise(p.cast(), size, libc::MADV_HUGEPAGE);
    }
    #[cfg(not(target_os = "linux"))]
    let _ = (p, size);
}

// SAFETY: every call is forwarded to `System`, with the caller's arguments or, for a large
// block, with a larger alignment that alloc and dealloc both derive from the same size and
// alignment (and the process-wide placement, fixed once read); the counting touches only
// atomics and never allocates.
unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = match placed(layout) {
            Some((l, huge)) => {
                // SAFETY: `l` has the caller's (non-zero) size and a larger power-of-two
                // alignment.
                let p = unsafe { System.alloc(l) };
                if huge && !p.is_null() {
                    advise(p, l.size());
                }
                p
            }
            // SAFETY: the caller's contract for `alloc`, passed on.
            None => unsafe { System.alloc(layout) },
        };
        if !p.is_null() {
            add(layout.size() as isize);
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if placed(layout).is_some_and(|(_, huge)| huge) {
            // Advised before the zeroing touches the pages.
            // SAFETY: the caller's contract for `alloc_zeroed` is `alloc`'s.
            let p = unsafe { self.alloc(layout) };
            if !p.is_null() {
                // SAFETY: `p` is a fresh block of `layout.size()` bytes.
                unsafe { std::ptr::write_bytes(p, 0, layout.size()) };
            }
            return p;
        }
        // SAFETY: the caller's contract for `alloc_zeroed`, passed on (with the alignment
        // `placed` gives).
        let p = unsafe { System.alloc_zeroed(placed(layout).map_or(layout, |p| p.0)) };
        if !p.is_null() {
            add(layout.size() as isize);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: the caller's contract for `dealloc`, passed on with the layout `alloc` used.
        unsafe { System.dealloc(ptr, placed(layout).map_or(layout, |p| p.0)) };
        add(-(layout.size() as isize));
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: `realloc`'s contract: `new_size` is non-zero and fits with the alignment.
        let new = unsafe { Layout::from_size_align_unchecked(new_size, layout.align()) };
        if placed(layout).is_some() || placed(new).is_some() {
            // Into or out of a placed block: a new block, the bytes copied, the old freed.
            // SAFETY: `new` is a valid non-zero layout.
            let q = unsafe { self.alloc(new) };
            if !q.is_null() {
                // SAFETY: both blocks hold at least the smaller size and do not overlap; `ptr`
                // was allocated by us with `layout`.
                unsafe {
                    std::ptr::copy_nonoverlapping(ptr, q, layout.size().min(new_size));
                    self.dealloc(ptr, layout);
                }
            }
            return q;
        }
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

    /// Large blocks get a cache line (a 2 MiB page with huge pages), small ones the caller's
    /// layout, and a caller's larger alignment is kept.
    #[test]
    fn large_layouts_are_placed() {
        let l = |size: usize, align: usize| Layout::from_size_align(size, align).unwrap();
        assert_eq!(placed(l(ALIGN_MIN - 1, 8)), None);
        if placement().align && !placement().huge {
            assert_eq!(placed(l(ALIGN_MIN, 8)), Some((l(ALIGN_MIN, LINE), false)));
            assert_eq!(placed(l(HUGE_MIN, 16)), Some((l(HUGE_MIN, LINE), false)));
            assert_eq!(placed(l(ALIGN_MIN, 128)), None);
        }
    }

    /// The harness's unit-test binary keeps the system allocator: no figure, not a zero.
    #[test]
    fn without_the_counting_allocator_nothing_is_reported() {
        assert!(!installed());
        let (v, used) = measure(|| vec![0u8; 1 << 16]);
        assert_eq!(v.len(), 1 << 16);
        assert_eq!(used, None);
    }
}
