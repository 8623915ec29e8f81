//! Time the hypervisor took from this machine's processors, for the watchdog's time limit.
//!
//! On a virtual machine the host may stop a virtual processor for a while (on the 2-vCPU
//! development VMs, for 100 ms at a time, several times a minute, whenever both are busy: the
//! host's CPU quota). The guest kernel counts that "stolen" time in `/proc/stat`'s `steal`
//! column, but unless it was built with `CONFIG_PARAVIRT_TIME_ACCOUNTING` it also charges it to
//! the thread that was running, so the thread's CPU clock — what the watchdog reads — runs on
//! while the thread does nothing. A decision of 20 µs that a stall catches then looks like 50 ms
//! of CPU time and was stopped as a runaway: `compare` on a loaded VM lost about one decision
//! in two runs, and its results depended on the load.
//!
//! So before the watchdog stops a call it subtracts the steal every processor accrued since the
//! call was first seen running long, and waits while a processor looks stopped: a stall's steal
//! is only written when the processor runs again (at its next tick), and until then the stalled
//! thread's clock is running on with nothing to subtract yet. A processor looks stopped when its
//! `/proc/stat` line has not moved for [`STALLED_NS`]; a running or idle one moves every tick
//! (idle time is counted live on a tickless idle processor).

/// Nanoseconds with no change in a processor's `/proc/stat` times after which it counts as
/// stopped by the host: a few ticks of the coarsest `CONFIG_HZ` (100) and of the file's unit.
pub const STALLED_NS: u64 = 30_000_000;

/// How long a call already past its limit is given while some processor looks stopped, at most:
/// a processor that never ticks (an isolated `nohz_full` one) must not keep a runaway running.
pub const GRACE_NS: u64 = 1_000_000_000;

/// The times of each processor in one reading of `/proc/stat`, in its unit (`USER_HZ` ticks).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CpuTimes {
    /// Per processor: the sum of its columns (every state, stolen time included).
    pub total: Vec<u64>,
    /// Per processor: the `steal` column.
    pub steal: Vec<u64>,
}

/// The per-processor lines (`cpu0 …`, `cpu1 …`) of a `/proc/stat` text; `None` if it has none
/// or a line has fewer than the eight columns up to `steal` (kernels before 2.6.11).
pub fn parse(text: &str) -> Option<CpuTimes> {
    let mut times = CpuTimes {
        total: Vec::new(),
        steal: Vec::new(),
    };
    for line in text.lines() {
        let Some(rest) = line.strip_prefix("cpu") else {
            continue;
        };
        // The first line, `cpu  …`, sums every processor.
        if !rest.starts_with(|c: char| c.is_ascii_digit()) {
            continue;
        }
        let columns: Vec<u64> = rest
            .split_ascii_whitespace()
            .skip(1)
            .map(str::parse)
            .collect::<Result<_, _>>()
            .ok()?;
        // user nice system idle iowait irq softirq steal; guest time is already in user.
        let steal = *columns.get(7)?;
        times.total.push(columns.iter().take(8).sum());
        times.steal.push(steal);
    }
    (!times.total.is_empty()).then_some(times)
}

/// What the watchdog knows of stolen time: the last reading and when each processor was last
/// seen to move.
#[derive(Debug)]
pub struct Watch {
    /// Nanoseconds of one `/proc/stat` unit.
    unit_ns: u64,
    last: Option<CpuTimes>,
    /// Per processor: when (the watchdog's clock, ns) a reading first showed it moved since
    /// the one before; `None` until one has.
    moved_at: Vec<Option<u64>>,
}

impl Watch {
    /// Empty; `unit_ns` is the length of `/proc/stat`'s unit (10 ms where `USER_HZ` is 100).
    pub fn new(unit_ns: u64) -> Self {
        Self {
            unit_ns: unit_ns.max(1),
            last: None,
            moved_at: Vec::new(),
        }
    }

    /// Takes in a reading made at `now` (`None`: the file could not be read or parsed; the
    /// watch then knows nothing, and the time limit is the CPU clock alone).
    pub fn update(&mut self, now: u64, reading: Option<CpuTimes>) {
        let Some(reading) = reading else {
            self.forget();
            return;
        };
        match &self.last {
            Some(last) if last.total.len() == reading.total.len() => {
                for ((moved, old), new) in self
                    .moved_at
                    .iter_mut()
                    .zip(&last.total)
                    .zip(&reading.total)
                {
                    if old != new {
                        *moved = Some(now);
                    }
                }
            }
            _ => {
                self.moved_at = vec![None; reading.total.len()];
            }
        }
        self.last = Some(reading);
    }

    /// Forgets when processors moved: readings stopped for a while, so a gap in them says
    /// nothing about a stall.
    pub fn forget(&mut self) {
        self.last = None;
        self.moved_at.clear();
    }

    /// The steal of every processor together at the last reading, ns; `None` with no reading.
    pub fn stolen_ns(&self) -> Option<u64> {
        let last = self.last.as_ref()?;
        Some(last.steal.iter().sum::<u64>().saturating_mul(self.unit_ns))
    }

    /// Whether some processor has not been seen to move within [`STALLED_NS`] before `now`
    /// (one never seen to move since the readings began counts as stopped).
    pub fn stalled(&self, now: u64) -> bool {
        self.moved_at
            .iter()
            .any(|m| m.is_none_or(|at| now.saturating_sub(at) > STALLED_NS))
    }
}

/// Whether a call that has used `used_ns` of its thread's CPU clock is past `limit_ns` once
/// `stolen_ns` (the steal accrued meanwhile, if known) is taken off; while `stalled` (some
/// processor looks stopped, so its steal is not written yet) it is given up to [`GRACE_NS`]
/// after it first looked past the limit (`waited_ns` ago).
pub fn past_limit(
    used_ns: u64,
    stolen_ns: Option<u64>,
    stalled: bool,
    waited_ns: u64,
    limit_ns: u64,
) -> bool {
    let Some(stolen) = stolen_ns else {
        return used_ns >= limit_ns;
    };
    used_ns.saturating_sub(stolen) >= limit_ns && (!stalled || waited_ns >= GRACE_NS)
}

#[cfg(test)]
mod tests {
    use super::*;

    const STAT: &str = "cpu  1961151 2 292160 1722074 5665 0 978 21877 0 0
cpu0 974541 2 142212 872533 1389 0 178 11018 0 0
cpu1 986609 0 149947 849541 4275 0 799 10859 0 0
intr 123 4 5
ctxt 99
";

    #[test]
    fn the_processor_lines_give_each_total_and_steal() {
        let t = parse(STAT).expect("parsed");
        assert_eq!(
            t.total,
            vec![
                974_541 + 2 + 142_212 + 872_533 + 1_389 + 178 + 11_018,
                986_609 + 149_947 + 849_541 + 4_275 + 799 + 10_859
            ]
        );
        assert_eq!(t.steal, vec![11_018, 10_859]);
    }

    #[test]
    fn a_stat_without_processor_lines_or_steal_is_not_read() {
        assert_eq!(parse("cpu  1 2 3 4 5 6 7 8\nintr 1\n"), None);
        assert_eq!(parse("cpu0 1 2 3 4\n"), None);
        assert_eq!(parse("cpu0 1 2 x 4 5 6 7 8\n"), None);
        assert_eq!(parse(""), None);
    }

    fn times(total: [u64; 2], steal: [u64; 2]) -> Option<CpuTimes> {
        Some(CpuTimes {
            total: total.to_vec(),
            steal: steal.to_vec(),
        })
    }

    #[test]
    fn a_processor_that_stops_moving_is_stalled_and_its_steal_counts_once_written() {
        let ms = 1_000_000;
        let mut w = Watch::new(10 * ms);
        w.update(0, times([100, 100], [5, 5]));
        // Nothing seen to move yet: unknown counts as stopped.
        assert!(w.stalled(0));
        w.update(10 * ms, times([101, 101], [5, 5]));
        assert!(!w.stalled(10 * ms));
        assert_eq!(w.stolen_ns(), Some(100 * ms));
        // Processor 1 stops: processor 0 moves on, 1 does not.
        for t in 2..=5 {
            w.update(t * 10 * ms, times([100 + t, 101], [5, 5]));
        }
        assert!(w.stalled(50 * ms), "41 ms without a move is a stall");
        assert!(!w.stalled(35 * ms));
        // It runs again: ten ticks of steal written at once.
        w.update(60 * ms, times([106, 112], [5, 15]));
        assert!(!w.stalled(60 * ms));
        assert_eq!(w.stolen_ns(), Some(200 * ms));
        w.forget();
        assert_eq!(w.stolen_ns(), None);
        assert!(
            !w.stalled(60 * ms),
            "no readings: nothing known to be stalled"
        );
    }

    #[test]
    fn stolen_time_is_not_the_calls_and_a_stall_delays_the_verdict_for_a_while() {
        let ms = 1_000_000;
        let limit = 50 * ms;
        // No steal known: the CPU clock alone, as before.
        assert!(past_limit(50 * ms, None, true, 0, limit));
        assert!(!past_limit(49 * ms, None, false, 0, limit));
        // A 20 µs decision caught by a 100 ms stall: its clock says 51 ms, 100 ms were stolen.
        assert!(!past_limit(51 * ms, Some(100 * ms), false, 0, limit));
        // A real runaway with a little steal meanwhile is still stopped.
        assert!(past_limit(61 * ms, Some(10 * ms), false, 0, limit));
        // Mid-stall the steal is not written yet: wait, but not past the grace.
        assert!(!past_limit(60 * ms, Some(0), true, 0, limit));
        assert!(!past_limit(60 * ms, Some(0), true, GRACE_NS - 1, limit));
        assert!(past_limit(60 * ms, Some(0), true, GRACE_NS, limit));
    }
}
