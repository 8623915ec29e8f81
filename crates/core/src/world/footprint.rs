//! How much memory a tank of fish takes, estimated before it is built, so that an impossible
//! count is refused up front with what it would take instead of running the machine out of
//! memory half-way through spawning.
//!
//! The figure per fish is measured, not derived: `shoal render` of a Lua scene of scripted
//! porgies (`behavior = "school"`), peak RSS from `/usr/bin/time -f %M` at two counts, the
//! slope between them: 5,000 fish 345 MiB and 25,000 fish 877 MiB in a debug build
//! (2026-11-28, 2-core VM, lavapipe) — 27 KiB a fish; issue 36 saw 2.9 GB at 200,000 fish in
//! `render` (14.5 KB a fish). The estimate uses the lower, so it refuses only counts that
//! cannot fit.

/// Bytes one simulated, scripted and drawn fish takes (see the module docs).
pub const BYTES_PER_FISH: u64 = 14_500;

/// The estimated memory of `fish` fish, bytes.
pub fn estimate_bytes(fish: u64) -> u64 {
    fish.saturating_mul(BYTES_PER_FISH)
}

/// Memory the system can still give a process, bytes (`MemAvailable` of `/proc/meminfo`);
/// `None` where that is not known (another system), in which case nothing is refused.
pub fn available_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib.saturating_mul(1024))
}

/// Too many fish for this machine's memory.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "{fish} fish would take about {} of memory ({} a fish, measured), and this machine has {} \
     available; use fewer fish (`shoal bench sim --fish N` measures large schools without \
     drawing them)",
    human(*need), human(BYTES_PER_FISH), human(*available)
)]
pub struct TooManyFish {
    /// The fish asked for.
    pub fish: u64,
    /// Their estimated memory, bytes.
    pub need: u64,
    /// The memory available, bytes.
    pub available: u64,
}

/// Refuses `fish` fish when their estimated memory exceeds `available` bytes (`None`: unknown,
/// nothing refused).
pub fn check_fits(fish: u64, available: Option<u64>) -> Result<(), TooManyFish> {
    let need = estimate_bytes(fish);
    match available {
        Some(available) if need > available => Err(TooManyFish {
            fish,
            need,
            available,
        }),
        _ => Ok(()),
    }
}

/// Bytes in the largest unit that keeps a number ≥ 1 (`14.2 KiB`, `135.0 GiB`).
pub fn human(bytes: u64) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut v = bytes as f64;
    let mut unit = 0;
    while v >= 1024.0 && unit + 1 < UNITS.len() {
        v /= 1024.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{bytes} B")
    } else {
        format!("{v:.1} {}", UNITS[unit])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_beyond_the_memory_are_refused_with_what_they_would_take() {
        let gib = 1u64 << 30;
        assert_eq!(check_fits(100_000, Some(8 * gib)), Ok(()));
        let e = check_fits(10_000_000, Some(8 * gib)).unwrap_err();
        assert_eq!(e.need, 10_000_000 * BYTES_PER_FISH);
        let msg = e.to_string();
        assert!(
            msg.starts_with("10000000 fish would take about 135.0 GiB") && msg.contains("8.0 GiB"),
            "{msg}"
        );
        assert_eq!(check_fits(u64::MAX, None), Ok(()));
        assert_eq!(human(512), "512 B");
        assert_eq!(human(1536), "1.5 KiB");
    }
}
