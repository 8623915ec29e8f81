//! One protected call's budget: the instructions, CPU time and memory it may use, why the host
//! stopped it ([`Abort`]), and where in the script it was (for messages). Shared by the sandbox's
//! hook, the bounded string functions and the debugger; it names none of them.

use std::sync::Mutex;
use std::sync::OnceLock;
use std::sync::atomic::{AtomicI64, AtomicU8, AtomicU64, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use mlua::Lua;

/// Why the running call was stopped by the host.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Abort {
    /// The instruction budget ran out.
    Budget,
    /// The state grew past the soft memory limit.
    Memory,
    /// The call ran past its time limit.
    Time,
}

/// Budget state shared between the host and the hook.
#[derive(Debug)]
pub struct Budget {
    /// Instructions left in the current call (negative once exhausted).
    pub(crate) remaining: AtomicI64,
    /// The budget the current call started with (for the message).
    pub(crate) granted: AtomicU64,
    /// How long the current call runs before it is metered, microseconds (0: counted from its
    /// first instruction; for the message).
    pub(crate) unmetered_us: AtomicU64,
    /// Set when the hook stopped the call; `pcall` rethrows while it is set
    /// (0: running, 1: [`Abort::Budget`], 2: [`Abort::Memory`]).
    pub(crate) abort: AtomicU8,
    /// Soft memory limit, bytes.
    pub(crate) soft_memory: usize,
    /// The state's watch slot (`usize::MAX`: none; then the time limit is read from the clock).
    pub(crate) slot: AtomicUsize,
    /// The current call's time limit, nanoseconds.
    pub(crate) time_limit_ns: AtomicU64,
    /// When the current call started (nanoseconds since [`epoch`]; states without a watch slot).
    pub(crate) started_ns: AtomicU64,
    /// The message the call was stopped with: raised again wherever the script is when the hook
    /// runs next (say, inside `pcall`), so the error keeps naming where it was stopped.
    pub(crate) message: Mutex<String>,
}

/// The clock origin of [`Budget::started_ns`].
fn epoch() -> Instant {
    static EPOCH: OnceLock<Instant> = OnceLock::new();
    *EPOCH.get_or_init(Instant::now)
}

fn since_epoch_ns() -> u64 {
    u64::try_from(epoch().elapsed().as_nanos()).unwrap_or(u64::MAX)
}

impl Budget {
    /// Arms the budget for a call of at most `instructions` instructions, counted from its first
    /// instruction.
    pub fn arm(&self, instructions: u64) {
        self.arm_after(instructions, Duration::ZERO);
    }

    /// Arms the budget for a call of at most `instructions` instructions counted once it has run
    /// `unmetered` (see [`Limits::metered_after`]).
    pub fn arm_after(&self, instructions: u64, unmetered: Duration) {
        self.remaining.store(
            i64::try_from(instructions).unwrap_or(i64::MAX),
            Ordering::Relaxed,
        );
        self.granted.store(instructions, Ordering::Relaxed);
        self.unmetered_us.store(
            u64::try_from(unmetered.as_micros()).unwrap_or(u64::MAX),
            Ordering::Relaxed,
        );
        self.abort.store(0, Ordering::Relaxed);
    }

    /// Instructions left in the current call (the debugger keeps them aside while it evaluates
    /// an expression under a budget of its own).
    pub(crate) fn remaining(&self) -> i64 {
        self.remaining.load(Ordering::Relaxed)
    }

    /// Gives the current call back the `remaining` instructions [`Budget::remaining`] read,
    /// clearing a stop an evaluation meanwhile ran into.
    pub(crate) fn restore(&self, remaining: i64) {
        self.remaining.store(remaining, Ordering::Relaxed);
        self.abort.store(0, Ordering::Relaxed);
    }

    /// Sets the current call's time limit. A state the watchdog watches has it enforced there;
    /// any other reads the clock now and the hook compares.
    pub fn limit_time(&self, limit: Duration) {
        self.time_limit_ns.store(
            u64::try_from(limit.as_nanos()).unwrap_or(u64::MAX),
            Ordering::Relaxed,
        );
        if self.slot.load(Ordering::Relaxed) == usize::MAX {
            self.started_ns.store(since_epoch_ns(), Ordering::Relaxed);
        }
    }

    /// Whether the current call has run past its time limit. Cheap (an atomic load) for a state
    /// the watchdog watches; host functions that can run long poll it.
    pub fn time_expired(&self) -> bool {
        let slot = self.slot.load(Ordering::Relaxed);
        if slot != usize::MAX {
            return crate::watchdog::expired(slot);
        }
        let limit = self.time_limit_ns.load(Ordering::Relaxed);
        since_epoch_ns().saturating_sub(self.started_ns.load(Ordering::Relaxed)) >= limit
    }

    /// The current call's time limit.
    pub fn time_limit(&self) -> Duration {
        Duration::from_nanos(self.time_limit_ns.load(Ordering::Relaxed))
    }

    /// Why the last call was stopped, if it was.
    pub fn aborted(&self) -> Option<Abort> {
        match self.abort.load(Ordering::Relaxed) {
            1 => Some(Abort::Budget),
            2 => Some(Abort::Memory),
            3 => Some(Abort::Time),
            _ => None,
        }
    }

    /// Stops the current call: `message` is its error, raised again wherever the script is
    /// next checked (so `pcall` cannot swallow it).
    pub fn stop(&self, why: Abort, message: String) -> mlua::Error {
        let v = match why {
            Abort::Budget => 1,
            Abort::Memory => 2,
            Abort::Time => 3,
        };
        if let Ok(mut m) = self.message.lock() {
            m.clone_from(&message);
        }
        self.abort.store(v, Ordering::Relaxed);
        mlua::Error::RuntimeError(message)
    }

    /// The error the current call was stopped with, if it was.
    pub(crate) fn stopped(&self) -> Option<mlua::Error> {
        self.aborted()?;
        let m = self.message.lock().ok()?.clone();
        Some(mlua::Error::RuntimeError(m))
    }
}

/// The message of a call stopped by its time limit.
pub fn time_message(limit: Duration) -> String {
    format!(
        "time limit exceeded ({} ms of CPU time per call)",
        limit.as_millis()
    )
}

/// `file:line` of the Lua function calling the current Rust callback (or `?`).
pub fn caller_location(lua: &Lua) -> String {
    for level in 1..4 {
        let loc = lua.inspect_stack(level, |d| {
            let src = d.source();
            let file = src.short_src.as_deref().unwrap_or("?").to_owned();
            (src.what != "C").then(|| format!("{file}:{}:", d.current_line().unwrap_or(0)))
        });
        match loc {
            Some(Some(s)) => return s,
            Some(None) => continue,
            None => break,
        }
    }
    "?:".to_owned()
}
