//! Metering Lua calls only when they run long.
//!
//! The instruction budget and the soft memory limit are checked by a count hook (see
//! `sandbox.rs`). While a count hook is set, Lua 5.4 checks it before *every* VM instruction,
//! which costs about 30 % of the interpreter's time in the shipped behaviours — and a behaviour
//! decision takes a few microseconds, so only a runaway one ever needs the hook. So on Linux a
//! call starts with no hook; a watchdog thread looks at the calls in flight every millisecond, and
//! once one has run longer than its delay ([`Limits::metered_after`](super::sandbox::Limits)) it
//! sends that call's thread a signal (`SIGURG`) whose handler sets the hook with `lua_sethook`.
//! That is the asynchronous use the Lua manual documents for `lua_sethook` (the `lua` program
//! stops a script on Ctrl-C the same way), and Lua 5.4 re-reads its hook flag at every backward
//! jump "to allow a signal to break the loop". From then on the call is metered: the budget
//! counts instructions and the memory limit is checked, so a runaway loop stops at its file and
//! line a millisecond or two later than it would under a hook set from the start.
//!
//! A call with a zero delay (loads, evaluations, tests that need determinism) is metered from its
//! first instruction, as is every call on other systems or when more than [`SLOTS`] Lua states
//! exist at once.
//!
//! The watchdog also enforces each call's time limit: once a call has used its limit of CPU time
//! (its thread's CPU clock, read by the watchdog: a call that is merely waiting for a busy
//! machine's processor is not stopped, nor one whose virtual processor the hypervisor stopped,
//! which that clock counts: see [`crate::stolen`]) it marks the call expired ([`expired`]) and
//! signals the thread again; the handler sets the hook to run before *every* instruction, and
//! the hook stops the call at the next one. Host functions that can run long (the sandbox's string functions)
//! poll [`expired`] themselves. Coroutines are Lua threads with hooks of their own: the sandbox creates them
//! through mlua, which gives them the budget hook for good (they are rare in behaviours).
//!
//! The watchdog also takes the profiler's stack samples ([`super::profiler`]). Where sampling is
//! on ([`Meter::set_sampling`]), it asks a tagged call in flight ([`Meter::set_tag`]: a decision,
//! tagged with its module) for a sample about every millisecond, with the same signal: the
//! handler arms the hook with a count of one, and the hook — on the Lua thread, at the next
//! instruction — records the stack and turns itself off again. A call already metered is not
//! re-armed: its budget hook takes the sample at its next run, so its instruction count is what
//! it would have been. The hook a watched state runs is therefore the watchdog's
//! (`metering_hook`), which runs mlua's budget hook when the call is metered.
//!
//! The unsafe code is the raw `lua_gethook`/`lua_sethook` calls (mlua cannot arm a hook from a
//! signal handler), installing the handler, sending the signal and the hook calling mlua's;
//! each block says why it is sound. The handler touches only atomics and `lua_sethook`.
#![allow(unsafe_code)]

use std::time::Duration;

use mlua::Lua;
use mlua::ffi;

use super::profiler::{AllocCount, NO_TAG, Sampler, main_thread};

/// Lua states that can be watched at once; more are metered from their first instruction.
pub const SLOTS: usize = 128;

/// How often the watchdog looks at the calls in flight.
#[cfg(target_os = "linux")]
const PERIOD: Duration = Duration::from_millis(1);

/// Looks the watchdog makes with no call in flight before it sleeps until the next call.
#[cfg(target_os = "linux")]
const IDLE_LOOKS: u32 = 200;

/// The hook of one Lua state: how to turn it on and off.
#[derive(Debug)]
pub struct Meter {
    /// The state's main thread (`lua_State*`).
    state: *mut ffi::lua_State,
    /// The budget hook mlua installed for the state's global hook.
    hook: ffi::lua_Hook,
    /// Instructions between two runs of the hook.
    interval: i32,
    /// This state's watch slot, if it has one.
    slot: Option<usize>,
    /// Where the stack samples of this state go (see [`super::profiler`]).
    sampler: Box<Sampler>,
    /// The allocation count of the state, once [`Meter::count_allocations`] installed it.
    alloc: Option<AllocCount>,
}

/// Whether the call in flight in watch slot `slot` has run past its time limit.
pub fn expired(slot: usize) -> bool {
    watch::expired(slot)
}

// SAFETY: `state` is only used on the thread that owns the `Meter`'s `ScriptHost` at the time
// (calls take `&self` of a host that is `&mut`-borrowed for the call, or owned by one lane), and
// by the signal handler on that same thread while a call is in flight. The Lua state itself is
// already `Send` (mlua's `send` feature).
unsafe impl Send for Meter {}
// SAFETY: as above: all uses go through one thread at a time.
unsafe impl Sync for Meter {}

impl Meter {
    /// Takes over the hook mlua's `set_global_hook` just installed on `lua`'s main thread (every
    /// `interval` instructions): turns it off and keeps it for [`Meter::call`].
    pub fn take_over(lua: &Lua, interval: u32) -> mlua::Result<Self> {
        let state = main_thread(lua)?;
        // SAFETY: `state` is `lua`'s live main thread, read on the thread that owns it.
        let hook = match unsafe { ffi::lua_gethook(state) } {
            Some(hook) => hook,
            None => {
                return Err(mlua::Error::runtime(
                    "the budget hook is not set on the Lua state",
                ));
            }
        };
        let sampler = Box::<Sampler>::default();
        let meter = Self {
            state,
            hook,
            interval: i32::try_from(interval).unwrap_or(i32::MAX).max(1),
            slot: watch::claim(state, hook, interval, &sampler),
            sampler,
            alloc: None,
        };
        meter.unhook();
        Ok(meter)
    }

    /// Counts the bytes `lua` (this meter's state) allocates from now on (see
    /// [`super::profiler`]); call after the memory limit is set. The owner of the state calls
    /// [`Meter::stop_counting_allocations`] before dropping it.
    pub fn count_allocations(&mut self, lua: &Lua) -> mlua::Result<()> {
        if self.alloc.is_none() {
            self.alloc = Some(AllocCount::install(lua)?);
        }
        Ok(())
    }

    /// Gives the state its own allocator back (the state must still be open).
    pub fn stop_counting_allocations(&mut self) {
        if let Some(a) = self.alloc.take() {
            a.uninstall();
        }
    }

    /// Bytes the state has allocated since [`Meter::count_allocations`] (0 before).
    pub fn allocated(&self) -> u64 {
        self.alloc.as_ref().map_or(0, AllocCount::allocated)
    }

    /// Samples the Lua stack of this state's calls about every `every` of their run (`None`:
    /// never, the default). Only calls under a tag ([`Meter::set_tag`]) are sampled, and only
    /// where the watchdog watches the state ([`Meter::watched`]).
    pub fn set_sampling(&self, every: Option<Duration>) {
        if let Some(slot) = self.slot {
            watch::set_sampling(slot, every);
        }
    }

    /// The tag the samples of the next calls are kept under (the module of a decision), or
    /// `None`: not sampled.
    pub fn set_tag(&self, tag: Option<usize>) {
        if let Some(slot) = self.slot {
            let tag = tag.and_then(|t| u32::try_from(t).ok()).unwrap_or(NO_TAG);
            watch::set_tag(slot, tag);
        }
    }

    /// The stack samples taken in this state's calls.
    pub fn sampler(&self) -> &Sampler {
        &self.sampler
    }

    /// Whether calls with a delay run unmetered until the watchdog sees them run long.
    pub fn watched(&self) -> bool {
        self.slot.is_some()
    }

    /// This state's watch slot (for [`expired`]), if it has one.
    pub fn slot(&self) -> Option<usize> {
        self.slot
    }

    /// Starts a call into Lua: metered from its first instruction if `metered_after` is zero or
    /// the state has no watch slot, else only once it has run that long; stopped once it has
    /// used `time_limit` of CPU time (where the state has a watch slot: see [`expired`]). The
    /// call ends when the guard drops (the hook is off again then).
    pub fn call(&self, metered_after: Duration, time_limit: Duration) -> Metered<'_> {
        let from_start = metered_after.is_zero() || self.slot.is_none();
        if from_start {
            self.hook_on();
        }
        let outer = self
            .slot
            .map(|slot| watch::begin(slot, metered_after, time_limit, from_start));
        Metered {
            meter: self,
            slot: self.slot,
            from_start,
            outer,
        }
    }

    fn hook_on(&self) {
        // A watched state gets the watchdog's hook, which runs mlua's and takes the samples
        // asked for; any other mlua's own.
        let hook = if self.slot.is_some() {
            watch::hook(self.hook)
        } else {
            self.hook
        };
        // SAFETY: `state` is the live main thread of the state this meter belongs to (the
        // `ScriptHost` owns both), used on the thread running the call; `hook` is mlua's hook
        // function for it, or the watchdog's, which calls it.
        unsafe { ffi::lua_sethook(self.state, Some(hook), ffi::LUA_MASKCOUNT, self.interval) }
    }

    fn unhook(&self) {
        // SAFETY: as in `hook_on`; a null hook with mask 0 turns hooks off.
        unsafe { ffi::lua_sethook(self.state, None, 0, 0) }
    }
}

impl Drop for Meter {
    fn drop(&mut self) {
        if let Some(slot) = self.slot {
            watch::release(slot);
        }
    }
}

/// A call in progress (see [`Meter::call`]); turns the hook off when dropped.
#[must_use = "the call is metered only while the guard lives"]
pub struct Metered<'a> {
    meter: &'a Meter,
    slot: Option<usize>,
    /// The hook was on from the call's first instruction.
    from_start: bool,
    /// The watched call this one runs inside on the same thread, if any (to restore).
    outer: Option<usize>,
}

impl Drop for Metered<'_> {
    fn drop(&mut self) {
        let outer = self.outer.unwrap_or(usize::MAX);
        let hooked = self.slot.is_some_and(|slot| watch::end(slot, outer));
        if hooked || self.from_start {
            self.meter.unhook();
        }
    }
}

#[cfg(target_os = "linux")]
mod watch {
    //! The watch slots, the watchdog thread, the signal handler and the hook they arm.

    use std::cell::Cell;
    use std::sync::OnceLock;
    use std::sync::atomic::{AtomicBool, AtomicI32, AtomicU32, AtomicU64, AtomicUsize, Ordering};
    use std::time::{Duration, Instant};

    use mlua::ffi;

    use super::{IDLE_LOOKS, NO_TAG, PERIOD, SLOTS, Sampler};
    use crate::stolen;

    /// A call in flight this long is watched for stolen time (see [`crate::stolen`]): the
    /// watchdog reads `/proc/stat` while one is, every [`READ_STAT_EVERY`].
    const LONG_NS: u64 = 2_000_000;

    /// How often `/proc/stat` is read while a long call is in flight.
    const READ_STAT_EVERY: u64 = 2_000_000;

    /// What the watchdog keeps of the call in flight in one slot.
    #[derive(Clone, Copy, Default)]
    struct Seen {
        /// The call (0: none yet).
        call: u64,
        /// When the watchdog first saw it, ns since the watchdog started.
        at: u64,
        /// Its thread's CPU time then.
        cpu: Option<u64>,
        /// The machine's stolen time when the call was first seen running long.
        stolen: Option<u64>,
        /// When it first looked past its time limit.
        over_since: Option<u64>,
    }

    /// One watched Lua state. Written by the thread running the state's calls (and read by the
    /// watchdog and the signal handler), except `meter_gen`, `sample_wanted` and `expired`,
    /// which the watchdog writes.
    struct Slot {
        taken: AtomicBool,
        /// The state's main thread (`lua_State*` as an address).
        state: AtomicUsize,
        /// Instructions between two runs of the hook.
        interval: AtomicU32,
        /// Kernel id of the thread running the call in flight.
        tid: AtomicI32,
        /// Number of the call in flight; 0 when none is.
        busy: AtomicU64,
        /// Calls begun so far (numbers the calls).
        calls: AtomicU64,
        /// How long the call in flight may run before it is metered, nanoseconds.
        after_ns: AtomicU64,
        /// The call the watchdog asked to meter (or that was metered from its start).
        meter_gen: AtomicU64,
        /// The call that was metered from its first instruction.
        from_start: AtomicU64,
        /// The signal handler set the budget hook for the call in flight.
        hooked: AtomicBool,
        /// CPU time the call in flight may use, nanoseconds.
        limit_ns: AtomicU64,
        /// The call the watchdog found past its time limit.
        expired: AtomicU64,
        /// The state's [`Sampler`] (an address; 0: none).
        sampler: AtomicUsize,
        /// Wall time between two stack samples of the state's calls, nanoseconds; 0: off.
        sample_ns: AtomicU64,
        /// The tag samples are kept under ([`NO_TAG`]: calls are not sampled).
        tag: AtomicU32,
        /// The call the watchdog asked for a sample of; 0 once taken.
        sample_wanted: AtomicU64,
        /// The handler armed the hook just to take a sample (the budget hook is off).
        sample_armed: AtomicBool,
    }

    impl Slot {
        const fn new() -> Self {
            Self {
                taken: AtomicBool::new(false),
                state: AtomicUsize::new(0),
                interval: AtomicU32::new(1),
                tid: AtomicI32::new(0),
                busy: AtomicU64::new(0),
                calls: AtomicU64::new(0),
                after_ns: AtomicU64::new(0),
                meter_gen: AtomicU64::new(0),
                from_start: AtomicU64::new(0),
                hooked: AtomicBool::new(false),
                limit_ns: AtomicU64::new(u64::MAX),
                expired: AtomicU64::new(0),
                sampler: AtomicUsize::new(0),
                sample_ns: AtomicU64::new(0),
                tag: AtomicU32::new(NO_TAG),
                sample_wanted: AtomicU64::new(0),
                sample_armed: AtomicBool::new(false),
            }
        }

        /// Whether the budget hook is on for call `call`.
        fn metering(&self, call: u64) -> bool {
            self.hooked.load(Ordering::SeqCst) || self.from_start.load(Ordering::SeqCst) == call
        }

        /// Instructions between two runs of the budget hook for call `call`: 1 once it is past
        /// its time limit (the next one stops it).
        fn count(&self, call: u64) -> i32 {
            if self.expired.load(Ordering::SeqCst) == call {
                1
            } else {
                i32::try_from(self.interval.load(Ordering::SeqCst)).unwrap_or(i32::MAX)
            }
        }
    }

    static TABLE: [Slot; SLOTS] = [const { Slot::new() }; SLOTS];

    thread_local! {
        /// The watched call running on this thread (its slot), for the hook.
        static CURRENT: Cell<usize> = const { Cell::new(usize::MAX) };
    }

    /// mlua's hook function (one function for every state), for the signal handler.
    static HOOK: OnceLock<ffi::lua_Hook> = OnceLock::new();

    /// The watchdog thread, started with the first watched call.
    static WATCHDOG: OnceLock<Option<std::thread::Thread>> = OnceLock::new();

    /// The watchdog is parked until the next call.
    static ASLEEP: AtomicBool = AtomicBool::new(false);

    /// The signal handler is installed.
    static HANDLER: OnceLock<bool> = OnceLock::new();

    /// A slot for the state, or `None` (then its calls are metered from the start).
    pub(super) fn claim(
        state: *mut ffi::lua_State,
        hook: ffi::lua_Hook,
        interval: u32,
        sampler: &Sampler,
    ) -> Option<usize> {
        let same_hook = *HOOK.get_or_init(|| hook) as usize == hook as usize;
        if !same_hook || !*HANDLER.get_or_init(install_handler) {
            return None;
        }
        let i = TABLE.iter().position(|s| {
            s.taken
                .compare_exchange(false, true, Ordering::AcqRel, Ordering::Acquire)
                .is_ok()
        })?;
        let s = &TABLE[i];
        s.busy.store(0, Ordering::SeqCst);
        s.hooked.store(false, Ordering::SeqCst);
        s.sample_armed.store(false, Ordering::SeqCst);
        s.sample_ns.store(0, Ordering::SeqCst);
        s.tag.store(NO_TAG, Ordering::SeqCst);
        s.interval.store(interval.max(1), Ordering::SeqCst);
        s.sampler
            .store(std::ptr::from_ref(sampler) as usize, Ordering::SeqCst);
        s.state.store(state as usize, Ordering::SeqCst);
        Some(i)
    }

    pub(super) fn release(slot: usize) {
        let s = &TABLE[slot];
        s.busy.store(0, Ordering::SeqCst);
        s.state.store(0, Ordering::SeqCst);
        s.sampler.store(0, Ordering::SeqCst);
        s.sample_ns.store(0, Ordering::SeqCst);
        s.taken.store(false, Ordering::Release);
    }

    /// The hook a watched state runs: the watchdog's (see [`metering_hook`]), which calls mlua's.
    pub(super) fn hook(_mlua: ffi::lua_Hook) -> ffi::lua_Hook {
        metering_hook
    }

    pub(super) fn set_sampling(slot: usize, every: Option<Duration>) {
        let ns = every.map_or(0, |d| {
            u64::try_from(d.as_nanos()).unwrap_or(u64::MAX).max(1)
        });
        TABLE[slot].sample_ns.store(ns, Ordering::SeqCst);
    }

    pub(super) fn set_tag(slot: usize, tag: u32) {
        TABLE[slot].tag.store(tag, Ordering::Relaxed);
    }

    /// Starts call of `slot`: metered after `after` (unless `hooked`, the hook already on),
    /// expired after `limit` of CPU time. Returns the watched call this one runs inside on this
    /// thread (`usize::MAX`: none), for [`end`].
    pub(super) fn begin(slot: usize, after: Duration, limit: Duration, hooked: bool) -> usize {
        let s = &TABLE[slot];
        let call = s.calls.load(Ordering::Relaxed).wrapping_add(1).max(1);
        s.calls.store(call, Ordering::Relaxed);
        s.tid.store(this_tid(), Ordering::SeqCst);
        s.after_ns.store(
            u64::try_from(after.as_nanos()).unwrap_or(u64::MAX),
            Ordering::SeqCst,
        );
        s.limit_ns.store(
            u64::try_from(limit.as_nanos()).unwrap_or(u64::MAX),
            Ordering::SeqCst,
        );
        if hooked {
            // Nothing to meter: the watchdog only watches the time limit.
            s.meter_gen.store(call, Ordering::SeqCst);
            s.from_start.store(call, Ordering::SeqCst);
        }
        let outer = CURRENT.with(|c| c.replace(slot));
        s.busy.store(call, Ordering::SeqCst);
        if ASLEEP.load(Ordering::SeqCst) || WATCHDOG.get().is_none() {
            wake_watchdog();
        }
        outer
    }

    /// The kernel id of the calling thread, asked once per thread: `gettid` is a system call
    /// (~0.2 µs on the 2-vCPU VM), and `begin` runs once per decision.
    fn this_tid() -> i32 {
        thread_local! {
            static TID: std::cell::Cell<i32> = const { std::cell::Cell::new(0) };
        }
        TID.with(|t| {
            if t.get() == 0 {
                // SAFETY: gettid has no preconditions.
                t.set(unsafe { libc::gettid() });
            }
            t.get()
        })
    }

    /// Whether the call in flight ran past its time limit.
    pub(super) fn expired(slot: usize) -> bool {
        let s = &TABLE[slot];
        let call = s.busy.load(Ordering::SeqCst);
        call != 0 && s.expired.load(Ordering::SeqCst) == call
    }

    /// CPU time thread `tid` of this process has used, nanoseconds.
    fn thread_cpu_ns(tid: i32) -> Option<u64> {
        // The clock of a thread by its kernel id, as Linux encodes it (the encoding glibc's
        // pthread_getcpuclockid uses): per-thread (4) scheduler clock (2) of `tid`.
        let clock = ((!tid) << 3) | 6;
        let mut ts = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: `ts` is a valid timespec to write; an unknown clock only returns an error.
        let rc = unsafe { libc::clock_gettime(clock, &mut ts) };
        (rc == 0).then(|| {
            u64::try_from(ts.tv_sec).unwrap_or(0) * 1_000_000_000
                + u64::try_from(ts.tv_nsec).unwrap_or(0)
        })
    }

    /// Ends the call in flight (`outer`: what [`begin`] returned); true if the handler set a
    /// hook (the caller turns it off).
    pub(super) fn end(slot: usize, outer: usize) -> bool {
        let s = &TABLE[slot];
        // Idle first: a signal arriving from here on finds no call to meter or sample.
        s.busy.store(0, Ordering::SeqCst);
        CURRENT.with(|c| c.set(outer));
        s.sample_wanted.store(0, Ordering::SeqCst);
        let sampling = s.sample_armed.swap(false, Ordering::SeqCst);
        s.hooked.swap(false, Ordering::SeqCst) || sampling
    }

    fn wake_watchdog() {
        let thread = WATCHDOG.get_or_init(|| {
            std::thread::Builder::new()
                .name("shoal-lua-watchdog".into())
                .spawn(watchdog)
                .ok()
                .map(|h| h.thread().clone())
        });
        if let Some(t) = thread {
            t.unpark();
        }
    }

    /// Looks at the calls in flight every [`PERIOD`]. A call's start is taken to be when the
    /// watchdog first saw it (so calls read no clock): a call is metered once it has been seen
    /// running for its delay, which is between that delay and one period more after it began.
    /// Where sampling is on, a call in flight is asked for a stack sample once its state's
    /// sampling interval has passed since the state's last one.
    fn watchdog() {
        let start = Instant::now();
        // Per slot: the call last seen in flight.
        let mut seen = [Seen::default(); SLOTS];
        // SAFETY: sysconf has no preconditions.
        let ticks_per_s = unsafe { libc::sysconf(libc::_SC_CLK_TCK) };
        let unit_ns = 1_000_000_000 / u64::try_from(ticks_per_s).unwrap_or(100).max(1);
        let mut stolen = stolen::Watch::new(unit_ns);
        // A long call was in flight at the last look; when `/proc/stat` was read last.
        let (mut long, mut read_at) = (false, None::<u64>);
        // Per slot: when its last sample was asked for.
        let mut sampled = [0u64; SLOTS];
        let mut idle = 0u32;
        loop {
            let now = u64::try_from(start.elapsed().as_nanos()).unwrap_or(u64::MAX);
            if !long {
                if read_at.take().is_some() {
                    stolen.forget();
                }
            } else if read_at.is_none_or(|at| now.saturating_sub(at) >= READ_STAT_EVERY) {
                let text = std::fs::read_to_string("/proc/stat").ok();
                stolen.update(now, text.as_deref().and_then(stolen::parse));
                read_at = Some(now);
            }
            long = false;
            let mut any = false;
            for ((s, seen), sampled) in TABLE.iter().zip(seen.iter_mut()).zip(sampled.iter_mut()) {
                let call = s.busy.load(Ordering::SeqCst);
                if call == 0 {
                    continue;
                }
                any = true;
                let tid = s.tid.load(Ordering::SeqCst);
                if seen.call != call {
                    *seen = Seen {
                        call,
                        at: now,
                        cpu: thread_cpu_ns(tid),
                        stolen: None,
                        over_since: None,
                    };
                }
                if now.saturating_sub(seen.at) >= LONG_NS {
                    long = true;
                    if seen.stolen.is_none() {
                        seen.stolen = stolen.stolen_ns();
                    }
                }
                if look(s, call, tid, now, seen, &stolen, sampled) {
                    // SAFETY: tgkill only sends a signal. Should the thread have finished the
                    // call (or even exited and its id been reused) meanwhile, the handler finds
                    // no call of that thread to meter and does nothing; SIGURG is otherwise
                    // ignored.
                    unsafe {
                        libc::syscall(libc::SYS_tgkill, libc::getpid(), tid, libc::SIGURG);
                    }
                }
            }
            if any {
                idle = 0;
            } else {
                idle += 1;
            }
            if idle >= IDLE_LOOKS {
                ASLEEP.store(true, Ordering::SeqCst);
                if TABLE.iter().all(|s| s.busy.load(Ordering::SeqCst) == 0) {
                    std::thread::park();
                }
                ASLEEP.store(false, Ordering::SeqCst);
                idle = 0;
            } else {
                std::thread::sleep(PERIOD);
            }
        }
    }

    /// One look at call `call` of slot `s` (first seen as `seen`): marks it expired, to be
    /// metered or to be sampled as due; true if its thread is to be signalled.
    fn look(
        s: &Slot,
        call: u64,
        tid: i32,
        now: u64,
        seen: &mut Seen,
        stolen: &stolen::Watch,
        sampled: &mut u64,
    ) -> bool {
        let limit = s.limit_ns.load(Ordering::SeqCst);
        if s.expired.load(Ordering::SeqCst) != call && now.saturating_sub(seen.at) >= limit {
            // Past the limit in wall time; stopped once its CPU time is too, less the time the
            // hypervisor took meanwhile (a thread whose clock cannot be read is stopped on wall
            // time).
            let used = match (seen.cpu, thread_cpu_ns(tid)) {
                (Some(then), Some(cpu)) => cpu.saturating_sub(then),
                _ => u64::MAX,
            };
            if used >= limit {
                let over_since = *seen.over_since.get_or_insert(now);
                let taken = seen
                    .stolen
                    .zip(stolen.stolen_ns())
                    .map(|(then, stolen)| stolen.saturating_sub(then));
                let waited = now.saturating_sub(over_since);
                if stolen::past_limit(used, taken, stolen.stalled(now), waited, limit) {
                    s.expired.store(call, Ordering::SeqCst);
                    return true;
                }
            }
        }
        let mut signal = false;
        let every = s.sample_ns.load(Ordering::SeqCst);
        if every > 0
            && s.tag.load(Ordering::Relaxed) != NO_TAG
            && now.saturating_sub(*sampled) >= every
            && s.sample_wanted.load(Ordering::SeqCst) != call
        {
            s.sample_wanted.store(call, Ordering::SeqCst);
            *sampled = now;
            signal = true;
        }
        if s.meter_gen.load(Ordering::SeqCst) == call {
            return signal;
        }
        // `after`/`tid` may already belong to a newer call of the slot: then that call is
        // metered a little early, which only costs it speed.
        let after = s.after_ns.load(Ordering::SeqCst);
        if now.saturating_sub(seen.at) < after {
            return signal;
        }
        s.meter_gen.store(call, Ordering::SeqCst);
        true
    }

    fn install_handler() -> bool {
        // SAFETY: the action is async-signal-safe: it reads and writes atomics, calls gettid and
        // lua_sethook (documented as safe to call from a signal handler), and allocates nothing.
        unsafe { signal_hook_registry::register(libc::SIGURG, on_signal).is_ok() }
    }

    fn on_signal() {
        // SAFETY: gettid has no preconditions.
        let me = unsafe { libc::gettid() };
        for s in &TABLE {
            let call = s.busy.load(Ordering::SeqCst);
            if call == 0 || s.tid.load(Ordering::SeqCst) != me {
                continue;
            }
            let state = s.state.load(Ordering::SeqCst) as *mut ffi::lua_State;
            let expired = s.expired.load(Ordering::SeqCst) == call;
            let metering = s.metering(call);
            // Past its time limit: the hook runs before every instruction, and stops the call.
            // Run long: the budget hook is turned on. Otherwise a sample asked for: the hook
            // runs once, at the next instruction. (A metered call's next budget hook run takes
            // the sample, leaving the count as it is.)
            let count = if expired || (s.meter_gen.load(Ordering::SeqCst) == call && !metering) {
                s.hooked.store(true, Ordering::SeqCst);
                s.count(call)
            } else if s.sample_wanted.load(Ordering::SeqCst) == call
                && !metering
                && !s.sample_armed.load(Ordering::SeqCst)
            {
                s.sample_armed.store(true, Ordering::SeqCst);
                1
            } else {
                continue;
            };
            // SAFETY: this thread is running a call of `state` (its slot is busy with this
            // thread's id), so the state is alive; we interrupted that call on its own thread,
            // which is how the Lua manual allows lua_sethook to be used asynchronously.
            unsafe { ffi::lua_sethook(state, Some(metering_hook), ffi::LUA_MASKCOUNT, count) };
        }
    }

    /// The hook of a watched state's main thread, on the Lua thread: takes the stack sample the
    /// watchdog asked for, then either runs mlua's budget hook (when the call is metered) or,
    /// when it was armed only for the sample, turns itself off again.
    unsafe extern "C-unwind" fn metering_hook(state: *mut ffi::lua_State, ar: *mut ffi::lua_Debug) {
        let Some(&budget_hook) = HOOK.get() else {
            return;
        };
        let slot = CURRENT.with(Cell::get);
        if let Some(s) = TABLE.get(slot) {
            let call = s.busy.load(Ordering::SeqCst);
            if call != 0 {
                if s.sample_wanted.load(Ordering::SeqCst) == call {
                    s.sample_wanted.store(0, Ordering::SeqCst);
                    let sampler = s.sampler.load(Ordering::SeqCst) as *const Sampler;
                    let tag = s.tag.load(Ordering::Relaxed);
                    if !sampler.is_null() {
                        // A panic must not unwind into Lua: a lost sample is all it can cost.
                        let _ = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                            // SAFETY: the sampler belongs to the meter of this slot's state,
                            // alive while its call is in flight (it is: `busy`); we run in
                            // that state's hook on its thread.
                            unsafe { (*sampler).record(state, tag) }
                        }));
                    }
                }
                if s.sample_armed.swap(false, Ordering::SeqCst) && !s.metering(call) {
                    // Armed only for the sample: off again, unless the handler has meanwhile
                    // turned the budget hook on or armed another sample (re-checked after, as
                    // the handler may run between any two of these steps).
                    // SAFETY: `state` is the running thread of a live state, in its hook.
                    unsafe { ffi::lua_sethook(state, None, 0, 0) };
                    let count = if s.metering(call) {
                        Some(s.count(call))
                    } else {
                        s.sample_armed.load(Ordering::SeqCst).then_some(1)
                    };
                    if let Some(count) = count {
                        // SAFETY: as above.
                        unsafe {
                            ffi::lua_sethook(state, Some(metering_hook), ffi::LUA_MASKCOUNT, count)
                        };
                    }
                    return;
                }
            }
        }
        // SAFETY: mlua's hook for this state, called as Lua would have called it (this hook
        // replaced it), with the same arguments; an error it raises unwinds through this frame,
        // which holds nothing to drop.
        unsafe { budget_hook(state, ar) }
    }
}

#[cfg(not(target_os = "linux"))]
mod watch {
    //! No watchdog on this system: every call is metered from its first instruction, and no
    //! call is sampled.

    use std::time::Duration;

    use mlua::ffi;

    use super::Sampler;

    pub(super) fn claim(
        _: *mut ffi::lua_State,
        _: ffi::lua_Hook,
        _: u32,
        _: &Sampler,
    ) -> Option<usize> {
        None
    }
    pub(super) fn release(_: usize) {}
    pub(super) fn hook(mlua: ffi::lua_Hook) -> ffi::lua_Hook {
        mlua
    }
    pub(super) fn set_sampling(_: usize, _: Option<Duration>) {}
    pub(super) fn set_tag(_: usize, _: u32) {}
    pub(super) fn begin(_: usize, _: Duration, _: Duration, _: bool) -> usize {
        usize::MAX
    }
    pub(super) fn expired(_: usize) -> bool {
        false
    }
    pub(super) fn end(_: usize, _: usize) -> bool {
        false
    }
}

/// Adds line events to the hook of `lua`'s main thread, which the watchdog has
/// just set to count instructions for the call about to start (its guard turns both off after).
pub(crate) fn add_line_hook(lua: &Lua) {
    let Ok(main) = main_thread(lua) else {
        return;
    };
    // SAFETY: `main` is `lua`'s live main thread. Reading its hook and setting it again with one
    // more event in the mask happens on the thread that owns the state, between calls.
    unsafe {
        let Some(hook) = ffi::lua_gethook(main) else {
            return;
        };
        let mask = ffi::lua_gethookmask(main) | ffi::LUA_MASKLINE;
        let count = ffi::lua_gethookcount(main);
        ffi::lua_sethook(main, Some(hook), mask, count);
    }
}
