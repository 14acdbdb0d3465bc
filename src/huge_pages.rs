//! The `prism` binary's global allocator: the system allocator, plus a transparent-huge-page
//! hint (Linux `madvise(MADV_HUGEPAGE)`) on every allocation of 2 MiB or more.
//!
//! Why: loading a 100k-triangle mesh and building its BVH touches ~75 MB of fresh memory
//! (vertex arrays, the BVH builder's node, Morton and decision arrays). With 4 KiB pages that
//! is ~19,000 page faults, 20-30 ms of kernel time on a 2-core VM: a fifth of the Blender
//! round trip's fixed overhead. Most distributions ship THP in `madvise` mode, where only
//! regions that ask for huge pages get them; with the hint the same load takes ~8,000 faults.
//! Small allocations are untouched, and so is every other platform (the hint is a no-op
//! there), so this changes only how the kernel backs large buffers, never their contents.

use std::alloc::{GlobalAlloc, Layout, System};

/// Allocations from this size on get the huge-page hint (one 2 MiB huge page on x86-64 and
/// most arm64 kernels; smaller ones could not contain an aligned huge page anyway).
const HUGE_PAGE_HINT_BYTES: usize = 2 << 20;

pub struct HugePageHintAllocator;

#[cfg(target_os = "linux")]
fn advise_huge_pages(ptr: *mut u8, size: usize) {
    const PAGE: usize = 4096;
    let start = (ptr as usize).next_multiple_of(PAGE);
    let end = (ptr as usize + size) & !(PAGE - 1);
    if end > start {
        // SAFETY: [start, end) lies inside the allocation just returned by the system
        // allocator and is page aligned; MADV_HUGEPAGE only changes how the kernel backs the
        // pages (it never changes their contents), and a failure (old kernel, THP disabled)
        // leaves ordinary pages, so the result is ignored.
        unsafe {
            libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE);
        }
    }
}

#[cfg(not(target_os = "linux"))]
fn advise_huge_pages(_ptr: *mut u8, _size: usize) {}

// SAFETY: every method forwards to `System` with the same arguments and returns its result;
// the hint does not read or write the memory.
unsafe impl GlobalAlloc for HugePageHintAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let ptr = unsafe { System.alloc(layout) };
        if layout.size() >= HUGE_PAGE_HINT_BYTES && !ptr.is_null() {
            advise_huge_pages(ptr, layout.size());
        }
        ptr
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let ptr = unsafe { System.alloc_zeroed(layout) };
        if layout.size() >= HUGE_PAGE_HINT_BYTES && !ptr.is_null() {
            advise_huge_pages(ptr, layout.size());
        }
        ptr
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let new_ptr = unsafe { System.realloc(ptr, layout, new_size) };
        if new_size >= HUGE_PAGE_HINT_BYTES && !new_ptr.is_null() {
            advise_huge_pages(new_ptr, new_size);
        }
        new_ptr
    }
}
