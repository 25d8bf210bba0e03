// How the process's heap returns freed memory to the system (glibc malloc).
#pragma once

namespace pfm {

/// Keeps freed heap memory in the process. glibc returns the free memory at the top of its heap
/// to the system whenever more than 128 kB is free there, and serves each block above 128 kB by
/// its own mapping, unmapped when freed (both limits rise only after a large block has been
/// freed, so they depend on the process's history). A run frees and allocates the same scratch
/// every step: without this policy the boundary detector's vectors come back as page faults on
/// every call (pfm-bench-detect counts page_faults per detection). With it freed memory stays
/// for reuse: trimming above 512 MB of free top, and no block served by a mapping of its own
/// (every block comes from the heap, where a freed one is reused without faulting its pages in
/// again). Call once at the start of main(); does nothing with another C library.
void keep_freed_memory();

}  // namespace pfm
