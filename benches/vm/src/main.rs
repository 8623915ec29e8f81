//! The scripting-VM evaluation of issue 18: the shipped `scripts/behaviors/school.lua` (with
//! `lib/common.lua`) deciding for a school of fish, under whichever VM this build's feature
//! picked (`lua54`, `luajit`, `luau`, `luau-jit`), with the guarantees shoal's sandbox promises
//! switched on, then probes of those guarantees.
//!
//! The `shoal` API the behaviour calls is a small mock in Rust over plain arrays (this file): the
//! same functions and return shapes as `crates/script/src/api/` (see `scripts/types/shoal.lua`), with a
//! uniform grid for the neighbour queries and a point-mass motion. The Rust side is the same in
//! every build, so the differences between builds are the VM's: interpreter or compiler, the
//! cost of crossing into Rust, the cost of the time bound.
//!
//! `cargo run --release --features luau -- [--fish 10000] [--seconds 5] [--no-bound]
//! [--no-memory-limit] [--jit-big] [--jit-off] [--scripts DIR]`

use std::cell::RefCell;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use mlua::{Function, Lua, LuaOptions, StdLib, Table, Value, VmState};

/// Which VM this build runs.
#[cfg(feature = "lua54")]
const VM: &str = "Lua 5.4";
#[cfg(feature = "luajit")]
const VM: &str = "LuaJIT";
#[cfg(all(feature = "luau", not(feature = "luau-jit")))]
const VM: &str = "Luau (interpreter)";
#[cfg(feature = "luau-jit")]
const VM: &str = "Luau (native codegen)";
#[cfg(not(any(
    feature = "lua54",
    feature = "luajit",
    feature = "luau",
    feature = "luau-jit"
)))]
compile_error!("pick a VM: --features lua54, luajit, luau or luau-jit");

const TICK_HZ: usize = 60;
/// Each fish decides every PERIOD-th tick (10 Hz), staggered, as in `shoal bench sim`.
const PERIOD: usize = 6;
const DT: f64 = 1.0 / TICK_HZ as f64;
/// Body lengths³ of water per fish, as `world::bench::VOLUME_PER_FISH_LENGTHS3`.
const VOLUME_PER_FISH_L3: f64 = 8.0;
/// Time bound per decision (shoal's default script time limit is of this order).
const CALL_LIMIT: Duration = Duration::from_millis(50);
/// Instructions between count-hook calls (shoal's `sandbox::HOOK_INTERVAL`).
const HOOK_INTERVAL: u32 = 1000;
/// Memory limit of the state, bytes.
const MEMORY_LIMIT: usize = 256 << 20;

#[derive(Clone)]
struct Options {
    fish: usize,
    seconds: f64,
    bound: bool,
    memory_limit: bool,
    jit_big: bool,
    jit_off: bool,
    scripts: PathBuf,
}

fn parse_args() -> Result<Options, String> {
    let mut o = Options {
        fish: 10_000,
        seconds: 5.0,
        bound: true,
        memory_limit: true,
        jit_big: false,
        jit_off: false,
        scripts: Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scripts"),
    };
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut value = |name: &str| args.next().ok_or(format!("{name} needs a value"));
        match a.as_str() {
            "--fish" => {
                o.fish = value("--fish")?
                    .parse()
                    .map_err(|e| format!("--fish: {e}"))?
            }
            "--seconds" => {
                o.seconds = value("--seconds")?
                    .parse()
                    .map_err(|e| format!("--seconds: {e}"))?
            }
            "--scripts" => o.scripts = PathBuf::from(value("--scripts")?),
            "--no-bound" => o.bound = false,
            "--no-memory-limit" => o.memory_limit = false,
            "--jit-big" => o.jit_big = true,
            "--jit-off" => o.jit_off = true,
            other => {
                return Err(format!(
                    "unknown argument {other}; use --fish N --seconds S --no-bound --no-memory-limit --jit-big --jit-off --scripts DIR"
                ));
            }
        }
    }
    if o.fish < 2 || !(o.seconds.is_finite() && o.seconds > 0.0) {
        return Err("--fish must be at least 2 and --seconds positive".into());
    }
    Ok(o)
}

/// A small deterministic generator (xorshift64*).
struct Rng(u64);
impl Rng {
    fn next_f64(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let v = self.0.wrapping_mul(0x2545_F491_4F6C_DD1D);
        (v >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[derive(Clone, Copy)]
struct SpeciesData {
    length: f64,
    cruise: f64,
    max_speed: f64,
    view: f64,
    cos_half: f64,
}

const PREY: SpeciesData = SpeciesData {
    length: 50.0,
    cruise: 50.0,
    max_speed: 120.0,
    view: 250.0,
    cos_half: -0.866,
};
const PRED: SpeciesData = SpeciesData {
    length: 80.0,
    cruise: 70.0,
    max_speed: 170.0,
    view: 500.0,
    cos_half: -0.866,
};

/// The mock world: structure of arrays, a uniform grid, food pellets.
struct World {
    x: Vec<f64>,
    y: Vec<f64>,
    z: Vec<f64>,
    heading: Vec<f64>,
    speed: Vec<f64>,
    predator: Vec<bool>,
    want: Vec<(f64, f64, f64)>,
    quick: Vec<bool>,
    min: [f64; 3],
    max: [f64; 3],
    cell: f64,
    dims: [usize; 3],
    cell_start: Vec<u32>,
    order: Vec<u32>,
    food: Vec<[f64; 3]>,
    rng: Rng,
    now: f64,
    cur: usize,
    /// Nanoseconds spent inside the mock API (sensing and requests) this run.
    api_ns: u64,
    api_calls: u64,
}

impl World {
    fn new(n: usize) -> Self {
        let l = PREY.length;
        let side = ((VOLUME_PER_FISH_L3 * n as f64 / 2.0).cbrt() * l).max(6.0 * l);
        let max = [2.0 * side, side, side];
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
        let mut w = World {
            x: Vec::new(),
            y: Vec::new(),
            z: Vec::new(),
            heading: Vec::new(),
            speed: Vec::new(),
            predator: Vec::new(),
            want: Vec::new(),
            quick: vec![false; n],
            min: [0.0; 3],
            max,
            cell: 6.0 * l,
            dims: [0; 3],
            cell_start: Vec::new(),
            order: Vec::new(),
            food: Vec::new(),
            rng: Rng(1),
            now: 0.0,
            cur: 0,
            api_ns: 0,
            api_calls: 0,
        };
        for i in 0..n {
            w.x.push(l + rng.next_f64() * (max[0] - 2.0 * l));
            w.y.push(l + rng.next_f64() * (max[1] - 2.0 * l));
            w.z.push(l + rng.next_f64() * (max[2] - 2.0 * l));
            let h = (rng.next_f64() * 2.0 - 1.0) * std::f64::consts::PI;
            w.heading.push(h);
            let pred = i % 100 == 0;
            w.predator.push(pred);
            let s = if pred { PRED.cruise } else { PREY.cruise };
            w.speed.push(s);
            w.want.push((h, max[1] - w.y[i], s));
        }
        for _ in 0..30 {
            let p = [
                rng.next_f64() * max[0],
                rng.next_f64() * max[1],
                rng.next_f64() * max[2],
            ];
            w.food.push(p);
        }
        let cell = w.cell;
        w.dims = max.map(|m| ((m / cell).ceil() as usize).max(1));
        w.rng = rng;
        w.rebuild_grid();
        w
    }

    fn cell_of(&self, i: usize) -> usize {
        let c = |v: f64, d: usize| ((v / self.cell) as usize).min(self.dims[d] - 1);
        (c(self.z[i], 2) * self.dims[1] + c(self.y[i], 1)) * self.dims[0] + c(self.x[i], 0)
    }

    fn rebuild_grid(&mut self) {
        let cells = self.dims[0] * self.dims[1] * self.dims[2];
        self.cell_start.clear();
        self.cell_start.resize(cells + 1, 0);
        for i in 0..self.x.len() {
            let c = self.cell_of(i);
            self.cell_start[c + 1] += 1;
        }
        for c in 0..cells {
            self.cell_start[c + 1] += self.cell_start[c];
        }
        let mut fill = self.cell_start.clone();
        self.order.resize(self.x.len(), 0);
        for i in 0..self.x.len() {
            let c = self.cell_of(i);
            self.order[fill[c] as usize] = i as u32;
            fill[c] += 1;
        }
    }

    /// Calls `f(j, dx, dy, dz, d2)` for every other fish within `r` of fish `i` in the fish's
    /// own grid cell (a 6-body-length cube): a cheap stand-in for shoal's sensing, whose cost
    /// is not what this evaluation compares (it is the same Rust in every build).
    fn neighbours(&self, i: usize, r: f64, mut f: impl FnMut(usize, f64, f64, f64, f64)) {
        let (px, py, pz) = (self.x[i], self.y[i], self.z[i]);
        let span = |v: f64, d: usize| {
            let c = ((v / self.cell) as usize).min(self.dims[d] - 1);
            (c, c)
        };
        let (x0, x1) = span(px, 0);
        let (y0, y1) = span(py, 1);
        let (z0, z1) = span(pz, 2);
        let r2 = r * r;
        for cz in z0..=z1 {
            for cy in y0..=y1 {
                let row = (cz * self.dims[1] + cy) * self.dims[0];
                let (a, b) = (
                    self.cell_start[row + x0] as usize,
                    self.cell_start[row + x1 + 1] as usize,
                );
                for &j in &self.order[a..b] {
                    let j = j as usize;
                    if j == i {
                        continue;
                    }
                    let (dx, dy, dz) = (self.x[j] - px, self.y[j] - py, self.z[j] - pz);
                    let d2 = dx * dx + dy * dy + dz * dz;
                    if d2 <= r2 {
                        f(j, dx, dy, dz, d2);
                    }
                }
            }
        }
    }

    fn species(&self, i: usize) -> SpeciesData {
        if self.predator[i] { PRED } else { PREY }
    }

    fn in_view(&self, i: usize, dx: f64, dz: f64, d: f64) -> bool {
        let (s, c) = self.heading[i].sin_cos();
        d < 1e-9 || (c * dx - s * dz) / d >= self.species(i).cos_half
    }

    /// Heading (0 = +x, + = left, towards −z) and depth towards a point.
    fn towards(&self, i: usize, x: f64, y: f64, z: f64) -> (f64, f64) {
        ((-(z - self.z[i])).atan2(x - self.x[i]), self.max[1] - y)
    }

    /// One 60 Hz motion step: turn towards the wish, ease speed and depth.
    fn step(&mut self) {
        for i in 0..self.x.len() {
            let (wh, wd, ws) = self.want[i];
            let rate = if self.quick[i] { 6.0 } else { 2.0 };
            let err = (wh - self.heading[i] + std::f64::consts::PI)
                .rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
            let turn = err.clamp(-rate * DT, rate * DT);
            self.heading[i] += turn;
            if err.abs() < 1e-3 {
                self.quick[i] = false;
            }
            self.speed[i] += (ws - self.speed[i]) * 0.033;
            let (s, c) = self.heading[i].sin_cos();
            let v = self.speed[i] * DT;
            self.x[i] += c * v;
            self.z[i] -= s * v;
            let target_y = self.max[1] - wd;
            self.y[i] += (target_y - self.y[i]).clamp(-0.5 * v, 0.5 * v);
            self.x[i] = self.x[i].clamp(self.min[0] + 1.0, self.max[0] - 1.0);
            self.y[i] = self.y[i].clamp(self.min[1] + 1.0, self.max[1] - 1.0);
            self.z[i] = self.z[i].clamp(self.min[2] + 1.0, self.max[2] - 1.0);
        }
        self.rebuild_grid();
    }

    /// Predators are driven here (not scripted): a slow wander.
    fn decide_predator(&mut self, i: usize) {
        let h = self.heading[i] + (self.rng.next_f64() - 0.5) * 0.8;
        self.want[i] = (h, self.max[1] - self.y[i], PRED.cruise);
    }

    /// FNV-1a over the bits of every fish's state: equal checksums mean identical runs.
    fn checksum(&self) -> u64 {
        let mut h = 0xcbf2_9ce4_8422_2325u64;
        for v in [&self.x, &self.y, &self.z, &self.heading, &self.speed] {
            for f in v.iter() {
                h = (h ^ f.to_bits()).wrapping_mul(0x100_0000_01b3);
            }
        }
        h
    }
}

type Shared = Rc<RefCell<World>>;

/// Runs `f` on the world as fish `cur`, timing it into `api_ns`.
fn api<R>(w: &Shared, f: impl FnOnce(&mut World, usize) -> R) -> R {
    let start = Instant::now();
    let mut w = w.borrow_mut();
    let cur = w.cur;
    let r = f(&mut w, cur);
    w.api_ns += start.elapsed().as_nanos() as u64;
    w.api_calls += 1;
    r
}

type Wish = (Option<f64>, Option<f64>, Option<f64>);

/// `nearest_raw`'s answer: id (nil when nothing is seen), x, y, z, distance, bearing, heading,
/// speed.
type Seen = (Option<i64>, f64, f64, f64, f64, f64, f64, f64);
const NOTHING_SEEN: Seen = (None, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);

/// The `shoal` table: the functions `school.lua` and `lib/common.lua` call.
fn make_api(lua: &Lua, w: &Shared) -> mlua::Result<Table> {
    let shoal = lua.create_table()?;
    let species: Vec<Table> = [PREY, PRED]
        .iter()
        .map(|s| {
            let t = lua.create_table()?;
            t.raw_set("length", s.length)?;
            t.raw_set("cruise_speed", s.cruise)?;
            t.raw_set("max_speed", s.max_speed)?;
            t.raw_set("view_range", s.view)?;
            t.raw_set("hunger_per_s", 0.01)?;
            t.raw_set("satiation_per_food", 0.4)?;
            t.raw_set("fear_decay_per_s", 0.2)?;
            t.raw_set("predator", s.length > 60.0)?;
            Ok(t)
        })
        .collect::<mlua::Result<_>>()?;
    let (ww, sp) = (w.clone(), species);
    shoal.set(
        "species",
        lua.create_function(move |_, ()| {
            Ok(api(&ww, |w, i| sp[usize::from(w.predator[i])].clone()))
        })?,
    )?;
    let ww = w.clone();
    let body_raw = lua.create_function(move |_, ()| {
        Ok(api(&ww, |w, i| {
            (
                w.x[i],
                w.y[i],
                w.z[i],
                w.max[1] - w.y[i],
                w.y[i],
                w.max[1] - w.y[i],
                w.heading[i],
                w.speed[i],
                if w.quick[i] { "quick_turn" } else { "swim" },
            )
        }))
    })?;
    let ww = w.clone();
    let nearest_raw = lua.create_function(move |_, kind: mlua::LuaString| {
        api(&ww, |w, i| {
            let view = w.species(i).view;
            let mut best: Option<(f64, usize, [f64; 3])> = None;
            let which = match kind.as_bytes().as_ref() {
                b"food" => {
                    for (k, f) in w.food.iter().enumerate() {
                        let (dx, dz) = (f[0] - w.x[i], f[2] - w.z[i]);
                        let dy = f[1] - w.y[i];
                        let d = (dx * dx + dy * dy + dz * dz).sqrt();
                        if d < view && w.in_view(i, dx, dz, d) && best.is_none_or(|b| d < b.0) {
                            best = Some((d, k + 1, *f));
                        }
                    }
                    0
                }
                b"predator" => {
                    w.neighbours(i, view, |j, dx, _, dz, d2| {
                        let d = d2.sqrt();
                        if w.predator[j] && w.in_view(i, dx, dz, d) && best.is_none_or(|b| d < b.0)
                        {
                            best = Some((d, j + 1, [w.x[j], w.y[j], w.z[j]]));
                        }
                    });
                    1
                }
                _ => return Ok(NOTHING_SEEN),
            };
            let Some((d, id, p)) = best else {
                return Ok(NOTHING_SEEN);
            };
            let (h, _) = w.towards(i, p[0], p[1], p[2]);
            let bearing = (h - w.heading[i] + std::f64::consts::PI)
                .rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
            let (hh, ss) = if which == 1 {
                (w.heading[id - 1], w.speed[id - 1])
            } else {
                (0.0, 0.0)
            };
            Ok((Some(id as i64), p[0], p[1], p[2], d, bearing, hh, ss))
        })
    })?;
    // As shoal's `api::WRAPPERS`: Rust returns plain values, Lua fills one reused table each;
    // time and tank answer from values staged once per tick.
    let wrappers = lua
        .load(
            r#"
local shoal, body_raw, nearest_raw = ...
local body, near, tank = {}, {}, {}
local now = 0
local function stage(time, x0, y0, z0, x1, y1, z1)
  now = time
  tank.min_x, tank.min_y, tank.min_z, tank.max_x, tank.max_y, tank.max_z = x0, y0, z0, x1, y1, z1
end
function shoal.body()
  local b = body
  b.x, b.y, b.z, b.depth, b.to_floor, b.to_surface, b.heading, b.speed, b.motion = body_raw()
  return b
end
function shoal.nearest(kind)
  local id, x, y, z, dist, bearing, heading, speed = nearest_raw(kind)
  if id == nil then return nil end
  local n = near
  n.id, n.x, n.y, n.z, n.distance, n.bearing, n.heading, n.speed =
    id, x, y, z, dist, bearing, heading, speed
  return n
end
function shoal.tank() return tank end
function shoal.time() return now end
return stage
"#,
        )
        .set_name("=wrappers")
        .into_function()?;
    let stage: Function = wrappers.call((&shoal, body_raw, nearest_raw))?;
    lua.set_named_registry_value("eval.stage", stage)?;
    let ww = w.clone();
    shoal.set(
        "avoid_obstacles",
        lua.create_function(move |_, ()| {
            // No rocks in this tank: nothing to avoid (three nils).
            api(&ww, |_, _| ());
            Ok(())
        })?,
    )?;
    let ww = w.clone();
    shoal.set(
        "avoid_walls",
        lua.create_function(move |_, margin: Option<f64>| {
            Ok(api(&ww, |w, i| -> Wish {
                let s = w.species(i);
                let m = margin.unwrap_or(2.0 * s.length);
                let depth = w.max[1] - w.y[i];
                if depth < m {
                    (Some(w.heading[i]), Some(m), Some(s.cruise))
                } else if w.y[i] < m {
                    (Some(w.heading[i]), Some(w.max[1] - m), Some(s.cruise))
                } else {
                    (None, None, None)
                }
            }))
        })?,
    )?;
    let ww = w.clone();
    shoal.set(
        "crowd",
        lua.create_function(
            move |_, (sr, sw, ar, aw, cr, cw): (f64, f64, f64, f64, f64, f64)| {
                Ok(api(&ww, |w, i| -> Wish {
                    let r = sr.max(ar).max(cr);
                    let (mut sep, mut ali, mut coh) = ([0.0f64; 3], [0.0f64; 2], [0.0f64; 3]);
                    let (mut na, mut nc) = (0usize, 0usize);
                    w.neighbours(i, r, |j, dx, dy, dz, d2| {
                        if d2 < sr * sr && d2 > 1e-9 {
                            sep[0] -= dx / d2;
                            sep[1] -= dy / d2;
                            sep[2] -= dz / d2;
                        }
                        if d2 < ar * ar {
                            let (s, c) = w.heading[j].sin_cos();
                            ali[0] += c;
                            ali[1] += s;
                            na += 1;
                        }
                        if d2 < cr * cr {
                            coh[0] += dx;
                            coh[1] += dy;
                            coh[2] += dz;
                            nc += 1;
                        }
                    });
                    if na + nc == 0 {
                        return (None, None, None);
                    }
                    let s = w.species(i);
                    let mut vx = sw * sep[0] * s.length;
                    let mut vz = sw * sep[2] * s.length;
                    if na > 0 {
                        vx += aw * ali[0] / na as f64;
                        vz -= aw * ali[1] / na as f64;
                    }
                    let mut dy = 0.0;
                    if nc > 0 {
                        let n = nc as f64 * s.length;
                        vx += cw * coh[0] / n;
                        vz += cw * coh[2] / n;
                        dy = coh[1] / nc as f64;
                    }
                    (
                        Some((-vz).atan2(vx)),
                        Some(w.max[1] - (w.y[i] + dy)),
                        Some(s.cruise),
                    )
                }))
            },
        )?,
    )?;
    let ww = w.clone();
    shoal.set(
        "steer",
        lua.create_function(move |_, (h, d, s): (f64, f64, Option<f64>)| {
            api(&ww, |w, i| {
                if !(h.is_finite() && d.is_finite()) {
                    return Err(mlua::Error::RuntimeError(
                        "shoal.steer: heading and depth must be finite".into(),
                    ));
                }
                let s = s.unwrap_or(w.species(i).cruise);
                w.want[i] = (h, d, s);
                Ok(())
            })
        })?,
    )?;
    let ww = w.clone();
    shoal.set(
        "quick_turn",
        lua.create_function(
            move |_, (angle, side, _now): (f64, mlua::LuaString, Option<bool>)| {
                api(&ww, |w, i| {
                    let sign = if side.as_bytes().as_ref() == b"left" {
                        1.0
                    } else {
                        -1.0
                    };
                    w.want[i].0 = w.heading[i] + sign * angle;
                    w.quick[i] = true;
                    Ok(())
                })
            },
        )?,
    )?;
    let ww = w.clone();
    shoal.set(
        "flee",
        lua.create_function(move |_, (x, y, z): (f64, f64, f64)| {
            Ok(api(&ww, |w, i| {
                let (h, _) = w.towards(i, x, y, z);
                (
                    h + std::f64::consts::PI,
                    w.max[1] - w.y[i],
                    w.species(i).max_speed,
                )
            }))
        })?,
    )?;
    let ww = w.clone();
    shoal.set(
        "arrive",
        lua.create_function(move |_, (x, y, z): (f64, f64, f64)| {
            Ok(api(&ww, |w, i| {
                let (h, d) = w.towards(i, x, y, z);
                (h, d, w.species(i).cruise)
            }))
        })?,
    )?;
    let ww = w.clone();
    shoal.set(
        "eat",
        lua.create_function(move |_, food: i64| {
            Ok(api(&ww, |w, i| {
                let k = (food - 1) as usize;
                let Some(f) = w.food.get(k).copied() else {
                    return false;
                };
                let d2 =
                    (f[0] - w.x[i]).powi(2) + (f[1] - w.y[i]).powi(2) + (f[2] - w.z[i]).powi(2);
                if d2 > (0.5 * w.species(i).length).powi(2) {
                    return false;
                }
                let m = w.max;
                let p = [
                    w.rng.next_f64() * m[0],
                    w.rng.next_f64() * m[1],
                    w.rng.next_f64() * m[2],
                ];
                w.food[k] = p;
                true
            }))
        })?,
    )?;
    let ww = w.clone();
    shoal.set(
        "wander",
        lua.create_function(move |_, turn: Option<f64>| {
            Ok(api(&ww, |w, i| {
                let t = turn.unwrap_or(0.6);
                let h = w.heading[i] + (w.rng.next_f64() * 2.0 - 1.0) * t;
                let l = w.species(i).length;
                let d = (w.max[1] - w.y[i] + (w.rng.next_f64() - 0.5) * l).clamp(l, w.max[1] - l);
                (h, d, w.species(i).cruise)
            }))
        })?,
    )?;
    let ww = w.clone();
    shoal.set(
        "random",
        lua.create_function(move |_, ()| Ok(api(&ww, |w, _| w.rng.next_f64())))?,
    )?;
    // For the crossing probe: one call with nothing to do, and one returning three numbers.
    shoal.set("noop", lua.create_function(|_, ()| Ok(()))?)?;
    shoal.set(
        "three",
        lua.create_function(|_, ()| Ok((1.0f64, 2.0f64, 3.0f64)))?,
    )?;
    // ... and one filling a reused 8-field table from Rust, as `nearest` and `body` do.
    let filled = lua.create_table()?;
    shoal.set(
        "fill",
        lua.create_function(move |_, ()| {
            for (k, v) in [
                "id", "x", "y", "z", "distance", "bearing", "heading", "speed",
            ]
            .into_iter()
            .zip(1..)
            {
                filled.raw_set(k, f64::from(v))?;
            }
            Ok(filled.clone())
        })?,
    )?;
    Ok(shoal)
}

/// Source of a behaviour file as this VM needs it. Lua 5.4's two-argument `math.atan(y, x)` is
/// `math.atan2` in LuaJIT and Luau (both silently ignore the second argument of `math.atan`):
/// the one edit the shipped behaviours need, made here so every VM runs the same logic.
fn source_for_vm(text: &str) -> String {
    if cfg!(feature = "lua54") {
        text.to_owned()
    } else {
        text.replace("math.atan(", "math.atan2(")
    }
}

/// Deadline of the running call (nanoseconds since `epoch`; 0 = none), checked by the bound.
struct Bound {
    epoch: Instant,
    deadline_ns: AtomicU64,
    checks: AtomicU64,
}

impl Bound {
    fn arm(&self, limit: Duration) {
        let ns = (self.epoch.elapsed() + limit).as_nanos() as u64;
        self.deadline_ns.store(ns, Ordering::Relaxed);
    }
    /// No deadline: calls outside a decision (staging the tick) are not bounded.
    fn disarm(&self) {
        self.deadline_ns.store(0, Ordering::Relaxed);
    }
    fn expired(&self) -> bool {
        self.checks.fetch_add(1, Ordering::Relaxed);
        let d = self.deadline_ns.load(Ordering::Relaxed);
        d != 0 && self.epoch.elapsed().as_nanos() as u64 > d
    }
}

/// The sandboxed state: only math, string and table (no io, os, debug, package), shared
/// libraries read-only (Luau: `Lua::sandbox`; Lua 5.4 and LuaJIT: each module family gets its
/// own copies, as shoal's `sandbox::module_env`), a bound on each call's time, a memory limit,
/// chunks named `@scripts/...` so errors say file:line.
struct Vm {
    lua: Lua,
    env: Option<Table>,
    bound: Arc<Bound>,
    memory_limit: Result<(), String>,
}

fn new_vm(o: &Options, w: &Shared) -> mlua::Result<Vm> {
    #[cfg(feature = "luajit")]
    let libs = StdLib::MATH | StdLib::STRING | StdLib::TABLE | StdLib::JIT;
    #[cfg(not(feature = "luajit"))]
    let libs = StdLib::MATH | StdLib::STRING | StdLib::TABLE;
    let lua = Lua::new_with(libs, LuaOptions::default())?;
    let memory_limit = lua
        .set_memory_limit(if o.memory_limit { MEMORY_LIMIT } else { 0 })
        .map(|_| ())
        .map_err(|e| e.to_string());
    #[cfg(feature = "luajit")]
    if o.jit_big {
        lua.load(r#"jit.opt.start("maxtrace=8000", "maxmcode=16384")"#)
            .exec()?;
    }
    // LuaJIT's interpreter only: the count hook then reaches every loop (it never reaches
    // compiled traces).
    #[cfg(feature = "luajit")]
    if o.jit_off {
        lua.load("jit.off()").exec()?;
    }
    #[cfg(not(feature = "luajit"))]
    let _ = (o.jit_big, o.jit_off);
    let bound = Arc::new(Bound {
        epoch: Instant::now(),
        deadline_ns: AtomicU64::new(0),
        checks: AtomicU64::new(0),
    });
    if o.bound {
        let b = bound.clone();
        #[cfg(feature = "luau")]
        lua.set_interrupt(move |_| {
            if b.expired() {
                Err(mlua::Error::RuntimeError(
                    "time limit of the call exceeded".into(),
                ))
            } else {
                Ok(VmState::Continue)
            }
        });
        #[cfg(not(feature = "luau"))]
        lua.set_global_hook(
            mlua::HookTriggers::new().every_nth_instruction(HOOK_INTERVAL),
            move |_, debug| {
                if b.expired() {
                    let src = debug.source();
                    Err(mlua::Error::RuntimeError(format!(
                        "{}:{}: time limit of the call exceeded",
                        src.short_src.as_deref().unwrap_or("?"),
                        debug.current_line().unwrap_or(0)
                    )))
                } else {
                    Ok(VmState::Continue)
                }
            },
        )?;
    }
    #[cfg(not(feature = "luau"))]
    let _ = HOOK_INTERVAL;
    let shoal = make_api(&lua, w)?;
    let g = lua.globals();
    // require: modules by dotted name under the scripts directory, loaded once, in the same
    // environment as the behaviour.
    let scripts = o.scripts.clone();
    let cache = lua.create_table()?;
    let require = lua.create_function(move |lua, name: String| {
        if let Some(v) = cache.raw_get::<Option<Value>>(name.as_str())? {
            return Ok(v);
        }
        let rel = format!("{}.lua", name.replace('.', "/"));
        let path = scripts.join(&rel);
        let text = std::fs::read_to_string(&path).map_err(|e| {
            mlua::Error::RuntimeError(format!("require {name}: {}: {e}", path.display()))
        })?;
        let mut chunk = lua
            .load(source_for_vm(&text))
            .set_name(format!("@scripts/{rel}"));
        if let Some(env) = lua.named_registry_value::<Option<Table>>("eval.env")? {
            chunk = chunk.set_environment(env);
        }
        let v: Value = chunk.call(())?;
        cache.raw_set(name.as_str(), v.clone())?;
        Ok(v)
    })?;
    #[cfg(feature = "luau")]
    {
        lua.set_compiler(mlua::chunk::Compiler::new().set_optimization_level(2));
        g.set("shoal", shoal)?;
        g.set("require", require)?;
        // Every library and global read-only; scripts write to their own environment.
        lua.sandbox(true)?;
        Ok(Vm {
            lua,
            env: None,
            bound,
            memory_limit,
        })
    }
    #[cfg(not(feature = "luau"))]
    {
        let env = lua.create_table()?;
        for name in [
            "assert",
            "error",
            "ipairs",
            "next",
            "pairs",
            "pcall",
            "rawequal",
            "rawget",
            "rawlen",
            "rawset",
            "select",
            "setmetatable",
            "getmetatable",
            "tonumber",
            "tostring",
            "type",
            "xpcall",
            "unpack",
            "print",
        ] {
            let v: Value = g.get(name)?;
            env.raw_set(name, v)?;
        }
        for lib in ["math", "string", "table"] {
            let copy = lua.create_table()?;
            for pair in g.get::<Table>(lib)?.pairs::<Value, Value>() {
                let (k, v) = pair?;
                copy.raw_set(k, v)?;
            }
            env.raw_set(lib, copy)?;
        }
        env.raw_set("shoal", shoal)?;
        env.raw_set("require", require)?;
        env.raw_set("_G", &env)?;
        lua.set_named_registry_value("eval.env", &env)?;
        Ok(Vm {
            lua,
            env: Some(env),
            bound,
            memory_limit,
        })
    }
}

/// The host's driver (shoal's `script::host` DRIVER): perceive, intend, behave. The fish tables
/// live in one Lua array, not as one mlua handle each: LuaJIT's C API stack (LUAI_MAXCSTACK,
/// 8,000 slots) holds mlua's handles, so 10,000 handles fail there ("out of Lua stack").
const DRIVER: &str = r#"
return function(mod, fishes, i)
  local fish = fishes[i]
  local perceive, intend, behave = mod.perceive, mod.intend, mod.behave
  local p, i
  if perceive then p = perceive(fish) end
  fish.percepts = p
  if intend then i = intend(fish, p) end
  fish.intention = i
  if behave then behave(fish, i, p) end
end
"#;

fn load(vm: &Vm, text: &str, name: &str) -> mlua::Result<Function> {
    let mut chunk = vm.lua.load(source_for_vm(text)).set_name(name);
    if let Some(env) = &vm.env {
        chunk = chunk.set_environment(env.clone());
    }
    chunk.into_function()
}

struct RunResult {
    us_per_decision: f64,
    api_us_per_decision: f64,
    api_calls_per_decision: f64,
    decisions: u64,
    checksum: u64,
    intentions: Vec<(String, u64)>,
    bound_checks_per_decision: f64,
    errors: u64,
}

/// Runs the school for one warm-up second and `seconds` measured, timing the decisions.
fn run(o: &Options, seconds: f64) -> mlua::Result<RunResult> {
    let w: Shared = Rc::new(RefCell::new(World::new(o.fish)));
    let vm = new_vm(o, &w)?;
    let path = o.scripts.join("behaviors/school.lua");
    let text = std::fs::read_to_string(&path)
        .map_err(|e| mlua::Error::RuntimeError(format!("{}: {e}", path.display())))?;
    let module: Table = load(&vm, &text, "@scripts/behaviors/school.lua")?.call(())?;
    let driver: Function = load(&vm, DRIVER, "=driver")?.call(())?;
    let stage: Function = vm.lua.named_registry_value("eval.stage")?;
    let fish = vm.lua.create_table_with_capacity(o.fish, 0)?;
    for i in 0..o.fish {
        let t = vm.lua.create_table()?;
        t.raw_set("memory", vm.lua.create_table()?)?;
        fish.raw_set(i + 1, t)?;
    }
    let warm = TICK_HZ;
    let ticks = warm + (seconds * TICK_HZ as f64).round().max(1.0) as usize;
    let (mut decide_ns, mut decisions, mut errors) = (0u64, 0u64, 0u64);
    let (mut api_ns0, mut api_calls0, mut checks0) = (0, 0, 0);
    for tick in 0..ticks {
        if tick == warm {
            let w = w.borrow();
            (api_ns0, api_calls0) = (w.api_ns, w.api_calls);
            checks0 = vm.bound.checks.load(Ordering::Relaxed);
        }
        w.borrow_mut().now = tick as f64 * DT;
        {
            let w = w.borrow();
            let (a, b) = (w.min, w.max);
            stage.call::<()>((w.now, a[0], a[1], a[2], b[0], b[1], b[2]))?;
        }
        let start = Instant::now();
        let mut n = 0;
        for i in (tick % PERIOD..o.fish).step_by(PERIOD) {
            if w.borrow().predator[i] {
                w.borrow_mut().decide_predator(i);
                continue;
            }
            w.borrow_mut().cur = i;
            vm.bound.arm(CALL_LIMIT);
            let result = driver.call::<()>((&module, &fish, i + 1));
            vm.bound.disarm();
            if let Err(e) = result {
                if errors == 0 {
                    eprintln!("decision error: {e}");
                }
                errors += 1;
            }
            n += 1;
        }
        if tick >= warm {
            decide_ns += start.elapsed().as_nanos() as u64;
            decisions += n;
        }
        w.borrow_mut().step();
    }
    let mut counts = std::collections::BTreeMap::<String, u64>::new();
    for f in fish.sequence_values::<Table>() {
        if let Some(s) = f?.raw_get::<Option<String>>("intention")? {
            *counts.entry(s).or_default() += 1;
        }
    }
    let w = w.borrow();
    let d = decisions.max(1) as f64;
    Ok(RunResult {
        us_per_decision: decide_ns as f64 / 1e3 / d,
        api_us_per_decision: (w.api_ns - api_ns0) as f64 / 1e3 / d,
        api_calls_per_decision: (w.api_calls - api_calls0) as f64 / d,
        decisions,
        checksum: w.checksum(),
        intentions: counts.into_iter().collect(),
        bound_checks_per_decision: (vm.bound.checks.load(Ordering::Relaxed) - checks0) as f64 / d,
        errors,
    })
}

/// Nanoseconds per call of `shoal.noop()`, `shoal.three()` and `shoal.fill()` from Lua beyond an
/// empty loop's iteration, and that iteration's.
fn crossing(o: &Options) -> mlua::Result<(f64, f64, f64, f64)> {
    let w: Shared = Rc::new(RefCell::new(World::new(16)));
    let vm = new_vm(o, &w)?;
    let probe = load(
        &vm,
        r#"
        local shoal, N = shoal, 200000
        local function run(kind)
          local t = 0
          if kind == 0 then for i = 1, N do t = t + i end
          elseif kind == 1 then for i = 1, N do shoal.noop() end
          elseif kind == 2 then for i = 1, N do local a, b, c = shoal.three(); t = t + c end
          else for i = 1, N do local p = shoal.fill(); t = t + p.x end end
          return t
        end
        return run, N
        "#,
        "=crossing",
    )?;
    let (run, n): (Function, f64) = probe.call(())?;
    let mut best = [f64::MAX; 4];
    for _ in 0..3 {
        for (k, b) in best.iter_mut().enumerate() {
            vm.bound.arm(Duration::from_secs(60));
            let start = Instant::now();
            run.call::<Value>(k)?;
            *b = b.min(start.elapsed().as_nanos() as f64 / n);
        }
    }
    Ok((
        best[0],
        best[1] - best[0],
        best[2] - best[0],
        best[3] - best[0],
    ))
}

/// Runs `code` in a fresh sandboxed state on its own thread with a 200 ms bound (memory: 4 s);
/// what happened, or "NOT stopped" when it still runs after 6 s (that thread is left spinning;
/// the process exits at the end).
fn probe(o: &Options, code: &str, name: &str) -> String {
    let (tx, rx) = std::sync::mpsc::channel();
    let (o, code, name) = (o.clone(), code.to_owned(), name.to_owned());
    let start = Instant::now();
    std::thread::spawn(move || {
        let w: Shared = Rc::new(RefCell::new(World::new(16)));
        let r = (|| -> mlua::Result<()> {
            let vm = new_vm(&o, &w)?;
            if let Err(e) = &vm.memory_limit
                && name == "memory"
            {
                return Err(mlua::Error::RuntimeError(format!(
                    "memory limit not available: {e}"
                )));
            }
            let f = load(&vm, &code, &format!("@scripts/behaviors/{name}.lua"))?;
            // The memory probe gets longer, so that the memory limit (not the time) stops it.
            let limit = if name == "memory" { 4000 } else { 200 };
            vm.bound.arm(Duration::from_millis(limit));
            f.call::<()>(())
        })();
        let _ = tx.send(r.map_err(|e| e.to_string()));
    });
    match rx.recv_timeout(Duration::from_secs(6)) {
        Ok(r) => {
            let ms = start.elapsed().as_secs_f64() * 1e3;
            match r {
                Ok(()) => format!("completed in {ms:.0} ms"),
                Err(msg) => format!(
                    "stopped after {ms:.0} ms: {}",
                    msg.lines().next().unwrap_or("")
                ),
            }
        }
        Err(_) => "NOT stopped after 6 s: the bound does not reach this code".to_owned(),
    }
}

fn main() {
    let o = match parse_args() {
        Ok(o) => o,
        Err(e) => {
            eprintln!("shoal-vm-eval: {e}");
            std::process::exit(2);
        }
    };
    if !o.scripts.join("behaviors/school.lua").is_file() {
        eprintln!(
            "shoal-vm-eval: {}: no behaviors/school.lua there (give --scripts DIR)",
            o.scripts.display()
        );
        std::process::exit(2);
    }
    let version = {
        let lua = Lua::new();
        lua.load("return (jit and jit.version) or _VERSION")
            .eval::<String>()
            .unwrap_or_default()
    };
    println!(
        "vm: {VM} ({version}); fish {}, {} s measured after 1 s; time bound per call: {}{}",
        o.fish,
        o.seconds,
        if !o.bound {
            "off".to_owned()
        } else if cfg!(feature = "luau") {
            format!("interrupt callback, {} ms", CALL_LIMIT.as_millis())
        } else {
            format!(
                "count hook every {HOOK_INTERVAL} instructions, {} ms",
                CALL_LIMIT.as_millis()
            )
        },
        if o.jit_off {
            "; jit.off() (interpreter only)"
        } else if o.jit_big {
            "; jit.opt.start(maxtrace=8000, maxmcode=16384)"
        } else {
            ""
        }
    );
    let r = match run(&o, o.seconds) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("shoal-vm-eval: {e}");
            std::process::exit(1);
        }
    };
    println!(
        "us/decision {:.3}  (inside the Rust API {:.3}; Lua {:.3})  api calls/decision {:.1}  \
         bound checks/decision {:.1}  decisions {}  errors {}",
        r.us_per_decision,
        r.api_us_per_decision,
        r.us_per_decision - r.api_us_per_decision,
        r.api_calls_per_decision,
        r.bound_checks_per_decision,
        r.decisions,
        r.errors
    );
    let total: u64 = r.intentions.iter().map(|(_, n)| n).sum();
    let mix: Vec<String> = r
        .intentions
        .iter()
        .map(|(k, n)| format!("{k} {:.1}%", 100.0 * *n as f64 / total.max(1) as f64))
        .collect();
    println!("last intentions: {}", mix.join("  "));
    // Determinism: two short runs from the same seed end in the same state.
    let short = Options {
        fish: o.fish.min(2000),
        seconds: 2.0,
        bound: o.bound,
        memory_limit: o.memory_limit,
        jit_big: o.jit_big,
        jit_off: o.jit_off,
        scripts: o.scripts.clone(),
    };
    match (run(&short, 2.0), run(&short, 2.0)) {
        (Ok(a), Ok(b)) => println!(
            "determinism: {} fish, 3 s twice: checksums {:016x} {:016x} ({})",
            short.fish,
            a.checksum,
            b.checksum,
            if a.checksum == b.checksum {
                "equal"
            } else {
                "DIFFER"
            }
        ),
        (a, b) => println!(
            "determinism: run failed: {:?} {:?}",
            a.err().map(|e| e.to_string()),
            b.err().map(|e| e.to_string())
        ),
    }
    match crossing(&o) {
        Ok((empty, noop, three, fill)) => println!(
            "crossing: shoal.noop() {noop:.1} ns/call, shoal.three() (3 numbers back) {three:.1} ns/call, \
             shoal.fill() (8 fields set from Rust) {fill:.1} ns/call, beyond an empty loop's {empty:.2} ns/iteration"
        ),
        Err(e) => println!("crossing: {e}"),
    }
    println!(
        "error: {}",
        probe(&o, "local t = nil\nlocal x = t.field\n", "error")
    );
    println!(
        "memory: {}",
        probe(
            &o,
            "local t = {}\nfor i = 1, 1e9 do t[i] = {i} end\n",
            "memory"
        )
    );
    println!(
        "sandbox: {}",
        probe(
            &o,
            "local seen = {}\n\
             for _, k in ipairs({'io', 'os', 'debug', 'package', 'load', 'loadstring', 'dofile', \
             'loadfile', 'getfenv', 'setfenv', 'collectgarbage', 'jit', 'ffi'}) do\n\
               if _G[k] ~= nil or rawget(_G, k) ~= nil then seen[#seen + 1] = k end\n\
             end\n\
             local ok = pcall(function() math.floor = nil end)\n\
             error('globals present: ' .. (#seen > 0 and table.concat(seen, ' ') or 'none of io/os/debug/package/load/jit') .. \
             '; math.floor = nil ' .. (ok and 'allowed (to this module family\\'s own copy)' or 'refused (read-only)'), 0)\n",
            "sandbox"
        )
    );
    if !o.bound {
        return;
    }
    println!(
        "bound, call loop: {}",
        probe(
            &o,
            "local function f(x) return x + 1 end\nlocal x = 0\nwhile true do x = f(x) end\n",
            "callloop"
        )
    );
    println!(
        "bound, tight loop: {}",
        probe(
            &o,
            "local x = 0\nwhile true do x = x + 1 end\n",
            "tightloop"
        )
    );
    // A probe that was not stopped still spins on its thread.
    std::process::exit(0);
}
