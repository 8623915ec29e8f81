//! Cache prefetch hints: ask the processor to start loading memory a later step will read, so
//! the load overlaps the work in between instead of stalling it. Used where the next item of a
//! loop is known but lives far from the current one (the next fish to decide: its motion player
//! and its Lua tables, scattered over a heap of 100,000 fish).
#![allow(unsafe_code)]

/// Cache line size assumed for spreading prefetches over an object.
pub const LINE: usize = 64;

/// Hints that the `lines` cache lines from `addr` will be read soon. Any address is fine: a
/// prefetch never faults and never changes memory, it only may fetch a line into the cache.
#[inline]
pub fn prefetch_lines(addr: *const u8, lines: usize) {
    #[cfg(target_arch = "x86_64")]
    for k in 0..lines {
        let p = addr.wrapping_add(k * LINE).cast::<i8>();
        // SAFETY: `_mm_prefetch` (SSE, part of the x86_64 baseline) is a hint with no
        // architectural effect: it does not fault on any address, valid or not, and writes
        // nothing. It needs `unsafe` only because it is a target-feature intrinsic.
        unsafe { std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (addr, lines);
}

/// Hints that `value` (all of it, up to `max_lines` lines) will be read soon.
#[inline]
pub fn prefetch<T>(value: &T, max_lines: usize) {
    let lines = std::mem::size_of::<T>().div_ceil(LINE).min(max_lines);
    prefetch_lines((value as *const T).cast::<u8>(), lines.max(1));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_prefetch_of_any_address_neither_faults_nor_writes() {
        // Null, unmapped and dangling addresses: a real load of any of these would crash.
        prefetch_lines(std::ptr::null(), 4);
        prefetch_lines(usize::MAX as *const u8, 2);
        prefetch_lines(0x10 as *const u8, 1);
        let b = Box::new([7u8; 300]);
        prefetch(&*b, 8);
        assert!(b.iter().all(|&x| x == 7));
        let freed = (&*Box::new(1u64) as *const u64).cast::<u8>();
        prefetch_lines(freed, 1);
    }
}
