//! Below the per-module profile: which *functions* of a behaviour take its time, and how many
//! bytes its decisions allocate.
//!
//! **Functions, by sampling.** No hook runs per instruction or per call for this. While sampling
//! is on, the watchdog thread (which already looks at the calls in flight every millisecond, see
//! [`super::watchdog`]) asks a call in flight for one sample about once a millisecond: it signals
//! the call's thread, the handler arms a one-shot count hook, and that hook, running on the Lua
//! thread at the next VM instruction, walks the Lua stack ([`Sampler::record`]) and turns itself
//! off again. A call already metered by the budget hook is sampled by that hook at its next run
//! instead, so its instruction count is untouched. Because samples are taken in time, a function's
//! share of its module's samples estimates its share of the module's measured CPU time; time in a
//! host function (a sensor query, the string library) lands on the Lua function that called it.
//!
//! **Memory, by counting.** The state's allocator (mlua's, which keeps the memory limit) is wrapped
//! by one that also adds up the bytes asked for ([`AllocCount`]); the host reads the total before
//! and after each decision, so each module is charged what its decisions allocated — the garbage
//! the collector later has to sweep. (What a module *holds* cannot be told apart this way: the
//! collector runs its steps inside whichever call allocates, freeing everyone's garbage.)
//!
//! The unsafe code is the stack walk (`lua_getstack`/`lua_getinfo`), reading the strings Lua hands
//! back, and the allocator wrapper; each block says why it is sound.
#![allow(unsafe_code)]

use std::collections::HashMap;
use std::ffi::{CStr, c_void};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

use mlua::{Lua, ffi};

/// Frames kept per sample, from the innermost: deeper stacks are cut at their outer end.
pub const MAX_DEPTH: usize = 48;

/// The tag of samples taken outside a decision (loads, evaluations): not kept.
pub const NO_TAG: u32 = u32::MAX;

/// One Lua function, as the samples name it.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
pub struct Frame {
    /// The file it is defined in, as errors name it (`scripts/behaviors/forage.lua`).
    pub file: String,
    /// The line its definition starts on (`function M.perceive(fish)`); 0 for a main chunk.
    pub line: u32,
    /// The name it was called by (`perceive`, `nearest`), or `function <file:line>` when its
    /// caller gave it none (an anonymous callback), or `main chunk`.
    pub name: String,
}

/// Frame ids of the functions defined on one line, by their chunk's source bytes.
type SameLine = Vec<(Box<[u8]>, u32)>;

/// The samples of one Lua state, by tag (the module of the decision in flight) and stack.
#[derive(Debug, Default)]
struct Store {
    frames: Vec<Frame>,
    /// Frame ids by line defined (a few sources share a line).
    ids: HashMap<i32, SameLine>,
    /// Sample counts by key: the tag, then frame ids from the outermost to the innermost.
    stacks: HashMap<Vec<u32>, u64>,
    /// The key being built (kept to spare an allocation per sample).
    scratch: Vec<u32>,
}

/// Where one Lua state's stack samples go (see the module docs). The samples are taken on the
/// state's own thread by the hook; readers take the lock between calls.
#[derive(Debug, Default)]
pub struct Sampler {
    store: Mutex<Store>,
    /// Samples taken.
    taken: AtomicU64,
}

/// Stacks counted: the tag they were taken under, their frames from the outermost to the
/// innermost (the innermost is the function that was running), and how often each was seen.
pub type Stacks = Vec<(u32, Vec<Frame>, u64)>;

impl Sampler {
    /// Forgets every sample.
    pub fn clear(&self) {
        let mut s = self.lock();
        s.stacks.clear();
        self.taken.store(0, Ordering::Relaxed);
    }

    /// Samples taken since the last [`Sampler::clear`].
    pub fn taken(&self) -> u64 {
        self.taken.load(Ordering::Relaxed)
    }

    /// Every stack seen, with its count.
    pub fn stacks(&self) -> Stacks {
        let s = self.lock();
        s.stacks
            .iter()
            .filter_map(|(key, &n)| {
                let (&tag, ids) = key.split_first()?;
                let frames = ids
                    .iter()
                    .filter_map(|&i| s.frames.get(i as usize).cloned())
                    .collect();
                Some((tag, frames, n))
            })
            .collect()
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Store> {
        // A panic while holding the lock can only have left a half-counted sample.
        self.store.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Records the stack `state` is running now, under `tag` (nothing under [`NO_TAG`]).
    ///
    /// # Safety
    /// `state` must be a live Lua thread, and this must run on the thread running it while Lua
    /// is stopped at a safe point: from a hook, as the watchdog's is.
    pub unsafe fn record(&self, state: *mut ffi::lua_State, tag: u32) {
        if tag == NO_TAG {
            return;
        }
        let mut guard = self.lock();
        let store = &mut *guard;
        store.scratch.clear();
        store.scratch.push(tag);
        let mut level = 0;
        while store.scratch.len() <= MAX_DEPTH {
            // SAFETY: lua_Debug is plain data (pointers and integers); all zeros is a valid
            // "not filled in" value, and lua_getstack fills in the part lua_getinfo needs.
            let mut ar: ffi::lua_Debug = unsafe { std::mem::zeroed() };
            // SAFETY: `state` is live and stopped in a hook on this thread (the caller's
            // contract); lua_getstack only reads the call chain and returns 0 past its end.
            if unsafe { ffi::lua_getstack(state, level, &mut ar) } == 0 {
                break;
            }
            level += 1;
            // SAFETY: `ar` was filled by lua_getstack for this state just now; "Sn" asks for
            // the source and the name, which neither allocate nor raise errors.
            if unsafe { ffi::lua_getinfo(state, c"Sn".as_ptr(), &mut ar) } == 0 {
                continue;
            }
            // SAFETY: lua_getinfo set `what` and `source` to strings Lua owns, alive while the
            // function is on the stack (it is, we are inside it); `source` has `srclen` bytes.
            let (what, source) = unsafe {
                (
                    cstr(ar.what),
                    if ar.source.is_null() {
                        &[][..]
                    } else {
                        std::slice::from_raw_parts(ar.source.cast::<u8>(), ar.srclen)
                    },
                )
            };
            // C functions (pcall, table.sort) and the host's own chunks are not the designer's.
            if what == b"C" || source.starts_with(b"=shoal") {
                continue;
            }
            // SAFETY: as above: `name` is null or a string Lua owns while the frame lives.
            let name = unsafe { cstr(ar.name) };
            let id = store.frame_id(source, ar.linedefined, name, what == b"main", &ar);
            store.scratch.push(id);
        }
        if store.scratch.len() == 1 {
            // No Lua frame of a script: the decision was in host code.
            return;
        }
        store.scratch[1..].reverse();
        match store.stacks.get_mut(store.scratch.as_slice()) {
            Some(n) => *n += 1,
            None => {
                let key = store.scratch.clone();
                store.stacks.insert(key, 1);
            }
        }
        self.taken.fetch_add(1, Ordering::Relaxed);
    }
}

/// The bytes of a C string, or none for a null pointer.
///
/// # Safety
/// `p` is null or a NUL-terminated string alive for the returned borrow.
unsafe fn cstr<'a>(p: *const std::ffi::c_char) -> &'a [u8] {
    if p.is_null() {
        &[]
    } else {
        // SAFETY: the caller's contract.
        unsafe { CStr::from_ptr(p) }.to_bytes()
    }
}

impl Store {
    /// The id of the function defined at `line` of `source`, named `name` by its caller.
    fn frame_id(
        &mut self,
        source: &[u8],
        line: i32,
        name: &[u8],
        main: bool,
        ar: &ffi::lua_Debug,
    ) -> u32 {
        let same_line = self.ids.entry(line).or_default();
        if let Some(&(_, id)) = same_line.iter().find(|(s, _)| &**s == source) {
            // A function called without a name first may be called by name later.
            let f = &mut self.frames[id as usize];
            if !name.is_empty() && f.name.starts_with("function <") {
                f.name = String::from_utf8_lossy(name).into_owned();
            }
            return id;
        }
        let file = match source.first() {
            Some(b'@' | b'=') => String::from_utf8_lossy(&source[1..]).into_owned(),
            // A chunk loaded from a string: Lua's own short form (`[string "..."]`).
            _ => {
                let short: Vec<u8> = ar
                    .short_src
                    .iter()
                    .take_while(|&&c| c != 0)
                    .map(|&c| c as u8)
                    .collect();
                String::from_utf8_lossy(&short).into_owned()
            }
        };
        let line_u = u32::try_from(line).unwrap_or(0);
        let name = if main {
            "main chunk".to_owned()
        } else if name.is_empty() {
            format!("function <{file}:{line_u}>")
        } else {
            String::from_utf8_lossy(name).into_owned()
        };
        let id = u32::try_from(self.frames.len()).unwrap_or(u32::MAX);
        self.frames.push(Frame {
            file,
            line: line_u,
            name,
        });
        same_line.push((source.into(), id));
        id
    }
}

/// What the samples of one module say about one of its functions.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct FunctionProfile {
    /// The function: its name, file and the line its definition starts on.
    #[serde(flatten)]
    pub frame: Frame,
    /// Samples in which it was the function running ("self").
    pub self_samples: u64,
    /// Samples in which it was on the stack, running or calling ("total").
    pub total_samples: u64,
    /// Its self samples as a share of the module's samples, 0–1.
    pub self_share: f64,
    /// Its total samples as a share of the module's samples, 0–1.
    pub total_share: f64,
    /// Estimated CPU milliseconds per simulated second of its own code (and the host functions
    /// it calls): its self share of the module's measured cost.
    pub self_ms_per_sim_s: f64,
    /// Estimated CPU milliseconds per simulated second with what it calls.
    pub total_ms_per_sim_s: f64,
}

/// A stack as a flame graph draws it: frames from the outermost, and its samples.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct StackProfile {
    /// `name (file:line)` of each frame, from the outermost to the function running.
    pub frames: Vec<String>,
    /// Samples of exactly this stack.
    pub samples: u64,
}

/// Per-function figures of one module from its stacks (outermost frame first) and its measured
/// cost, most self time first. `ms_per_sim_s` is the module's measured CPU time per simulated
/// second.
pub fn functions<'a>(
    stacks: impl IntoIterator<Item = (&'a [Frame], u64)>,
    ms_per_sim_s: f64,
) -> Vec<FunctionProfile> {
    let mut by_frame: HashMap<&Frame, (u64, u64)> = HashMap::new();
    let mut all = 0u64;
    for (frames, n) in stacks {
        let Some(leaf) = frames.last() else {
            continue;
        };
        all += n;
        by_frame.entry(leaf).or_default().0 += n;
        // Recursion counts a function once per sample in its total.
        for (i, f) in frames.iter().enumerate() {
            if !frames[..i].contains(f) {
                by_frame.entry(f).or_default().1 += n;
            }
        }
    }
    let share = |n: u64| if all == 0 { 0.0 } else { n as f64 / all as f64 };
    let mut out: Vec<FunctionProfile> = by_frame
        .into_iter()
        .map(|(f, (own, total))| FunctionProfile {
            frame: f.clone(),
            self_samples: own,
            total_samples: total,
            self_share: share(own),
            total_share: share(total),
            self_ms_per_sim_s: share(own) * ms_per_sim_s,
            total_ms_per_sim_s: share(total) * ms_per_sim_s,
        })
        .collect();
    out.sort_by(|a, b| {
        b.self_samples
            .cmp(&a.self_samples)
            .then(b.total_samples.cmp(&a.total_samples))
            .then_with(|| a.frame.cmp(&b.frame))
    });
    out
}

/// The stacks of one module merged by frame and sorted by samples, most first, at most `keep`.
pub fn flame<'a>(
    stacks: impl IntoIterator<Item = (&'a [Frame], u64)>,
    keep: usize,
) -> Vec<StackProfile> {
    let mut merged: HashMap<Vec<String>, u64> = HashMap::new();
    for (frames, n) in stacks {
        let names = frames
            .iter()
            .map(|f| format!("{} ({}:{})", f.name, f.file, f.line))
            .collect();
        *merged.entry(names).or_default() += n;
    }
    let mut out: Vec<StackProfile> = merged
        .into_iter()
        .map(|(frames, samples)| StackProfile { frames, samples })
        .collect();
    out.sort_by(|a, b| {
        b.samples
            .cmp(&a.samples)
            .then_with(|| a.frames.cmp(&b.frames))
    });
    out.truncate(keep);
    out
}

/// The allocator wrapper behind the per-module memory figures: mlua's allocator (which keeps the
/// memory limit), plus a count of the bytes asked for. Lives in the state's app data, so it
/// outlives `lua_close`, which still allocates through it.
struct Counting {
    inner: ffi::lua_Alloc,
    inner_ud: *mut c_void,
    /// Bytes asked for: new blocks, and the growth of grown ones.
    allocated: AtomicU64,
}

// SAFETY: `inner_ud` is mlua's allocator state, only used by the allocator, which runs on
// whichever thread runs the state (one at a time, as for the state itself).
unsafe impl Send for Counting {}
// SAFETY: as above; the counter is atomic.
unsafe impl Sync for Counting {}

/// The app-data slot holding the wrapper (private, so nothing else can replace it).
struct CountingSlot(#[allow(dead_code)] Box<Counting>);

/// A handle on the allocation count of one Lua state (see [`AllocCount::install`]).
#[derive(Debug)]
pub struct AllocCount {
    /// The main thread of the state.
    state: *mut ffi::lua_State,
    counting: *const Counting,
}

// SAFETY: the pointers are only used while the state lives (the owner of the state owns this
// handle too) and by one thread at a time, as the state itself.
unsafe impl Send for AllocCount {}
// SAFETY: as above; reading the counter is an atomic load.
unsafe impl Sync for AllocCount {}

impl std::fmt::Debug for Counting {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Counting")
            .field("allocated", &self.allocated)
            .finish()
    }
}

/// Lua's allocator contract (see `lua_Alloc` in the manual), forwarding to mlua's and counting.
unsafe extern "C" fn counting_alloc(
    ud: *mut c_void,
    ptr: *mut c_void,
    osize: usize,
    nsize: usize,
) -> *mut c_void {
    // SAFETY: `ud` is the `Counting` installed with this function (see `AllocCount::install`),
    // alive until after lua_close.
    let c = unsafe { &*ud.cast::<Counting>() };
    // With a null `ptr`, `osize` is a type tag, not a size.
    let old = if ptr.is_null() { 0 } else { osize };
    if nsize > old {
        // One thread at a time runs the state: a plain add (no locked instruction) is enough.
        let n = c.allocated.load(Ordering::Relaxed);
        c.allocated
            .store(n.wrapping_add((nsize - old) as u64), Ordering::Relaxed);
    }
    // SAFETY: mlua's allocator called with its own state and the arguments Lua gave us.
    unsafe { (c.inner)(c.inner_ud, ptr, osize, nsize) }
}

impl AllocCount {
    /// Wraps `lua`'s allocator with a counting one. Call once, after `set_memory_limit` (mlua
    /// recognises its own allocator to change the limit; `used_memory` still works, through the
    /// collector's count). Call [`AllocCount::uninstall`] before the state is dropped, to hand
    /// mlua its allocator back (otherwise mlua cannot free its small allocator state).
    pub fn install(lua: &mlua::Lua) -> mlua::Result<Self> {
        let state = main_thread(lua)?;
        let mut inner_ud = std::ptr::null_mut();
        // SAFETY: `state` is `lua`'s live main thread, read on the thread that owns it.
        let inner = unsafe { ffi::lua_getallocf(state, &mut inner_ud) };
        let counting = Box::new(Counting {
            inner,
            inner_ud,
            allocated: AtomicU64::new(0),
        });
        let p: *const Counting = &*counting;
        // Kept by the state until after it closes (app data is dropped after lua_close).
        lua.set_app_data(CountingSlot(counting));
        // SAFETY: `state` as above; `p` points into the box now owned by the state's app data.
        // Lua allows lua_setallocf at any time the state is not allocating, which it is not
        // while we run.
        unsafe { ffi::lua_setallocf(state, counting_alloc, p.cast_mut().cast()) };
        Ok(Self { state, counting: p })
    }

    /// Bytes the state has asked its allocator for since [`AllocCount::install`].
    pub fn allocated(&self) -> u64 {
        // SAFETY: the box lives as long as the state, which the owner of this handle keeps.
        unsafe { &*self.counting }.allocated.load(Ordering::Relaxed)
    }

    /// Gives mlua its allocator back. The state must still be open.
    pub fn uninstall(&self) {
        // SAFETY: the state is open (the caller's contract: the owner calls this before
        // dropping it); the inner allocator and its state are the ones it had before.
        unsafe {
            let c = &*self.counting;
            ffi::lua_setallocf(self.state, c.inner, c.inner_ud);
        }
    }
}

/// `lua`'s main thread (`lua_State*`, never null): the state the hooks and the allocator belong
/// to, alive as long as `lua`. An error if the registry holds none (it always does).
pub(crate) fn main_thread(lua: &Lua) -> mlua::Result<*mut ffi::lua_State> {
    let mut main = std::ptr::null_mut();
    // SAFETY: `exec_raw` hands us a valid state with room on its stack; we push one value (the
    // main thread, from the registry) and pop it again.
    unsafe {
        lua.exec_raw::<()>((), |state| {
            ffi::lua_rawgeti(state, ffi::LUA_REGISTRYINDEX, ffi::LUA_RIDX_MAINTHREAD);
            main = ffi::lua_tothread(state, -1);
            ffi::lua_pop(state, 1);
        })?;
    }
    if main.is_null() {
        return Err(mlua::Error::runtime("the Lua state has no main thread"));
    }
    Ok(main)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(name: &str, line: u32) -> Frame {
        Frame {
            file: "scripts/behaviors/x.lua".into(),
            line,
            name: name.into(),
        }
    }

    #[test]
    fn self_and_total_shares_from_stacks() {
        let (tick, heavy, light) = (frame("tick", 1), frame("heavy", 5), frame("light", 9));
        let a = [tick.clone(), heavy.clone()];
        let b = [tick.clone(), light.clone()];
        let c = [tick.clone()];
        let f = functions([(&a[..], 80), (&b[..], 8), (&c[..], 12)], 50.0);
        assert_eq!(f[0].frame, heavy);
        assert_eq!((f[0].self_samples, f[0].total_samples), (80, 80));
        assert!((f[0].self_share - 0.8).abs() < 1e-12);
        assert!((f[0].self_ms_per_sim_s - 40.0).abs() < 1e-9);
        let t = f.iter().find(|p| p.frame == tick).unwrap();
        assert_eq!((t.self_samples, t.total_samples), (12, 100));
        assert!((t.total_ms_per_sim_s - 50.0).abs() < 1e-9);
        assert!(functions(std::iter::empty(), 1.0).is_empty());
    }

    #[test]
    fn recursion_counts_once_in_total() {
        let r = frame("r", 3);
        let s = [r.clone(), r.clone(), r.clone()];
        let f = functions([(&s[..], 10)], 1.0);
        assert_eq!((f[0].self_samples, f[0].total_samples), (10, 10));
    }

    #[test]
    fn flame_merges_equal_stacks() {
        let a = [frame("tick", 1), frame("heavy", 5)];
        let fl = flame([(&a[..], 3), (&a[..], 4)], 10);
        assert_eq!(fl.len(), 1);
        assert_eq!(fl[0].samples, 7);
        assert_eq!(fl[0].frames[1], "heavy (scripts/behaviors/x.lua:5)");
    }
}
