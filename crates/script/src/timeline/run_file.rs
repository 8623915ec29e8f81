//! The recording format (`.shoalrun`), version 2: self-describing, checked, written atomically.
//! Version 2 adds the header's `inputs` (a behaviour test's actions on its world); version 1
//! files still read.
//!
//! ```text
//! "SHOALRUN"              8 bytes, the magic
//! format                  u32 little-endian (2)
//! header length           u64, then the header as JSON (RunHeader: scene, seed, lanes, shoal
//!                         version, every script's text and checksum, where a replay came from,
//!                         the inputs from outside the scripts by tick)
//! frames length           u64, then the frames: per recorded tick, u32 fish count and per fish
//!                         u32 slot index, u32 generation, f32 x, y, z, f32 heading
//! checksum                u32, CRC-32 of everything before it
//! ```
//!
//! A recording holds what is needed to run it again (scene, seed, lanes and the scripts' text),
//! and what it showed (every fish's pose at every tick), so `shoal replay` can re-run the past
//! with edited scripts and `shoal diff` can compare two runs without running either.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use glam::Vec3;

/// The format this shoal writes and reads.
pub const FORMAT: u32 = 2;

const MAGIC: &[u8; 8] = b"SHOALRUN";

/// Bytes of one fish's pose in a frame.
const POSE_BYTES: usize = 24;

/// One script file as recorded.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ScriptFile {
    /// CRC-32 of its text.
    pub crc32: u32,
    /// Its text.
    pub text: String,
}

/// Where a replay came from.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ReplayOf {
    /// The recording replayed (as given on the command line).
    pub run: String,
    /// Time the new scripts took over, seconds.
    pub from_s: f64,
    /// Script files (relative paths) that differ from the replayed recording's.
    pub changed: Vec<String>,
}

/// What a recording is of: enough to run it again.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunHeader {
    /// The shoal version that wrote it.
    pub shoal_version: String,
    /// The scene file, relative to the scripts directory (`scenes/default.lua`).
    pub scene: String,
    /// The simulation's seed.
    pub seed: u64,
    /// Script lanes the simulation ran in.
    pub lanes: usize,
    /// Ticks per second.
    pub tick_hz: f64,
    /// The tank (lower and upper corner), for plots.
    pub tank: [[f32; 3]; 2],
    /// Every `.lua` file of the scripts directory, by path relative to it.
    pub scripts: BTreeMap<String, ScriptFile>,
    /// Set when this recording is a replay of another with other scripts.
    pub replay_of: Option<ReplayOf>,
    /// What was done to the world from outside the scripts, by tick (a behaviour test's
    /// spawns, food, rocks, motion requests); empty for a scene simply run. Format 2.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub inputs: Vec<super::inputs::TimedInput>,
    /// Whether behaviour level of detail was on (recordings from before it existed: off). Its
    /// bands and headless focus are the recorded scene's; a focus that moved is in `inputs`.
    #[serde(default)]
    pub lod: bool,
}

/// One fish's pose in a frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Slot index of its handle.
    pub index: u32,
    /// Generation of its handle.
    pub generation: u32,
    /// Root position, world units.
    pub pos: Vec3,
    /// Heading, radians.
    pub heading: f32,
}

impl Pose {
    /// Whether two poses are the same bit for bit (what "not diverged" means).
    pub fn same_as(&self, other: &Pose) -> bool {
        self.index == other.index
            && self.generation == other.generation
            && self.pos.to_array().map(f32::to_bits) == other.pos.to_array().map(f32::to_bits)
            && self.heading.to_bits() == other.heading.to_bits()
    }
}

/// A recording: its header and one frame per tick (frame `k` is the world after `k` ticks).
#[derive(Clone, Debug, PartialEq)]
pub struct Run {
    /// What it is of.
    pub header: RunHeader,
    /// Every fish's pose, per tick, starting with the state before the first tick.
    pub frames: Vec<Vec<Pose>>,
}

/// Why a recording could not be read or written. Each names the file.
#[derive(Debug, thiserror::Error)]
pub enum RunFileError {
    /// The file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// Not a recording at all.
    #[error("{path}: not a shoal recording (it does not start with SHOALRUN)")]
    NotARun {
        /// The file.
        path: PathBuf,
    },
    /// Written by a newer shoal.
    #[error(
        "{path}: recording format {found}, but this shoal reads format {FORMAT}; open it with the \
         shoal that wrote it or a newer one"
    )]
    NewerFormat {
        /// The file.
        path: PathBuf,
        /// The format it claims.
        found: u32,
    },
    /// Shorter than its own lengths say.
    #[error("{path}: truncated: {what} needs {needed} bytes, {left} are left")]
    Truncated {
        /// The file.
        path: PathBuf,
        /// Which part.
        what: &'static str,
        /// Bytes that part needs.
        needed: u64,
        /// Bytes left in the file.
        left: u64,
    },
    /// The bytes do not match their checksum.
    #[error("{path}: corrupt: the checksum does not match its contents")]
    Corrupt {
        /// The file.
        path: PathBuf,
    },
    /// The header is not valid.
    #[error("{path}: bad header: {why}")]
    Header {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        why: String,
    },
    /// The frames are not valid.
    #[error("{path}: bad frames: {source}")]
    Frames {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        source: FramesError,
    },
}

impl Run {
    /// Seconds the recording covers.
    pub fn seconds(&self) -> f64 {
        self.frames.len().saturating_sub(1) as f64 / self.header.tick_hz
    }

    /// Time of frame `k`, seconds.
    pub fn time_of(&self, k: usize) -> f64 {
        k as f64 / self.header.tick_hz
    }

    /// The recording as bytes (see the module docs).
    pub fn to_bytes(&self) -> Vec<u8> {
        let header = serde_json::to_vec(&self.header).expect("a header always serializes");
        let poses: usize = self.frames.iter().map(Vec::len).sum();
        let mut frames = Vec::with_capacity(self.frames.len() * 4 + poses * POSE_BYTES);
        for frame in &self.frames {
            frames.extend((frame.len() as u32).to_le_bytes());
            for p in frame {
                frames.extend(p.index.to_le_bytes());
                frames.extend(p.generation.to_le_bytes());
                for v in [p.pos.x, p.pos.y, p.pos.z, p.heading] {
                    frames.extend(v.to_le_bytes());
                }
            }
        }
        let mut out = Vec::with_capacity(32 + header.len() + frames.len());
        out.extend(MAGIC);
        out.extend(FORMAT.to_le_bytes());
        out.extend((header.len() as u64).to_le_bytes());
        out.extend(&header);
        out.extend((frames.len() as u64).to_le_bytes());
        out.extend(&frames);
        let crc = crc32fast::hash(&out);
        out.extend(crc.to_le_bytes());
        out
    }

    /// Writes the recording to `path` atomically (a temporary file beside it, then renamed), so
    /// a reader never sees half a file.
    pub fn write(&self, path: &Path) -> Result<(), RunFileError> {
        let io = |source| RunFileError::Io {
            path: path.to_path_buf(),
            source,
        };
        let dir = path
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let mut tmp = tempfile::NamedTempFile::new_in(dir).map_err(io)?;
        tmp.write_all(&self.to_bytes()).map_err(io)?;
        tmp.as_file().sync_all().map_err(io)?;
        tmp.persist(path).map_err(|e| io(e.error))?;
        Ok(())
    }

    /// Reads a recording, checking its magic, format, lengths and checksum.
    pub fn read(path: &Path) -> Result<Run, RunFileError> {
        let bytes = std::fs::read(path).map_err(|source| RunFileError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_bytes(&bytes, path)
    }

    /// Parses a recording's bytes (`path` names it in errors).
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Run, RunFileError> {
        let path_buf = || path.to_path_buf();
        if bytes.len() < MAGIC.len() || &bytes[..MAGIC.len()] != MAGIC {
            return Err(RunFileError::NotARun { path: path_buf() });
        }
        let mut r = Reader {
            bytes,
            at: MAGIC.len(),
            path,
        };
        let format = u32::from_le_bytes(r.take::<4>("the format number")?);
        if format > FORMAT {
            return Err(RunFileError::NewerFormat {
                path: path_buf(),
                found: format,
            });
        }
        let header_len = u64::from_le_bytes(r.take::<8>("the header length")?);
        let header = r.slice(header_len, "the header")?;
        let frames_len = u64::from_le_bytes(r.take::<8>("the frames length")?);
        let frames = r.slice(frames_len, "the frames")?;
        let body_end = r.at;
        let crc = u32::from_le_bytes(r.take::<4>("the checksum")?);
        if crc32fast::hash(&bytes[..body_end]) != crc {
            return Err(RunFileError::Corrupt { path: path_buf() });
        }
        // The field's path in front of serde's reason: `tank[1][2]: number out of range`.
        let header: RunHeader =
            serde_path_to_error::deserialize(&mut serde_json::Deserializer::from_slice(header))
                .map_err(|e| RunFileError::Header {
                    path: path_buf(),
                    why: match e.path().to_string().as_str() {
                        "." => e.inner().to_string(),
                        field => format!("{field}: {}", e.inner()),
                    },
                })?;
        let frames = parse_frames(frames).map_err(|source| RunFileError::Frames {
            path: path_buf(),
            source,
        })?;
        check_header(&header, frames.len()).map_err(|why| RunFileError::Header {
            path: path_buf(),
            why,
        })?;
        Ok(Run { header, frames })
    }
}

/// What is wrong with a recording's frames (see [`RunFileError::Frames`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FramesError {
    /// The bytes end before a frame's fish count.
    #[error("frame {0} has no fish count")]
    NoCount(usize),
    /// A frame counts more fish than there are bytes left.
    #[error("frame {frame} says {fish} fish, more than the bytes left")]
    TooManyFish {
        /// The frame.
        frame: usize,
        /// The fish it says it has.
        fish: usize,
    },
    /// No frame at all.
    #[error("no frames")]
    None,
}

/// The most script lanes a recording may ask for: a lane is a whole Lua state, and shoal
/// itself runs at most one per thread (16 by default). A file asking for more is refused
/// before any state is built.
pub const MAX_LANES: usize = 256;

/// Whether `rel` (a recording's script or scene path) stays inside the scripts directory: a
/// relative `/`-separated path without `..`, empty or odd parts.
fn inside_scripts(rel: &str) -> bool {
    !rel.is_empty()
        && !rel.starts_with('/')
        && !rel.contains('\\')
        && !rel.contains('\0')
        && !rel.contains(':')
        && rel
            .split('/')
            .all(|c| !c.is_empty() && c != "." && c != "..")
}

/// Checks every header field against what shoal can run, so that a mutated or hand-edited
/// recording (its checksum recomputed) is refused with one line naming the field instead of
/// reaching the simulation: `lanes: 1000000000 is out of range: expected 1 to 256`.
/// `num_frames` is the number of frames the file holds.
fn check_header(h: &RunHeader, num_frames: usize) -> Result<(), String> {
    if !(1..=MAX_LANES).contains(&h.lanes) {
        return Err(format!(
            "lanes: {} is out of range: expected 1 to {MAX_LANES} script lanes",
            h.lanes
        ));
    }
    let tick_hz = shoal_core::world::TICK_HZ;
    if h.tick_hz != tick_hz {
        return Err(format!(
            "tick_hz: {:?} is not shoal's tick rate ({tick_hz} ticks a second), the only one it \
             runs and replays",
            h.tick_hz
        ));
    }
    let [min, max] = h.tank;
    for (corner, v) in [("min", min), ("max", max)] {
        if let Some(x) = v.iter().find(|x| !x.is_finite()) {
            return Err(format!("tank.{corner}: {x} is not a finite number"));
        }
    }
    if (0..3).any(|i| min[i] >= max[i]) {
        return Err(format!(
            "tank: min {min:?} must be below max {max:?} on every axis"
        ));
    }
    if h.scripts.is_empty() {
        return Err("scripts: none; a recording keeps every script it ran".into());
    }
    for (rel, file) in &h.scripts {
        if !inside_scripts(rel) || !rel.ends_with(".lua") {
            return Err(format!(
                "scripts: `{rel}` is not a .lua file inside the scripts directory"
            ));
        }
        if crc32fast::hash(file.text.as_bytes()) != file.crc32 {
            return Err(format!("scripts.{rel}: its crc32 does not match its text"));
        }
    }
    if !inside_scripts(&h.scene) {
        return Err(format!(
            "scene: `{}` is not a path inside the scripts directory",
            h.scene
        ));
    }
    if !h.scripts.contains_key(&h.scene) {
        return Err(format!(
            "scene: `{}` is not among the recording's scripts",
            h.scene
        ));
    }
    let last_tick = num_frames.saturating_sub(1) as u64;
    for (k, timed) in h.inputs.iter().enumerate() {
        if timed.tick > last_tick {
            return Err(format!(
                "inputs: one at tick {}, after the recording's last frame (tick {last_tick})",
                timed.tick
            ));
        }
        check_input(&timed.input).map_err(|why| format!("inputs[{}].{why}", k + 1))?;
    }
    if let Some(r) = &h.replay_of {
        let seconds = last_tick as f64 / tick_hz;
        if !(r.from_s.is_finite() && (0.0..=seconds).contains(&r.from_s)) {
            return Err(format!(
                "replay_of.from_s: {:?} is not a time inside the recording (0 to {seconds:.2} s)",
                r.from_s
            ));
        }
        for rel in &r.changed {
            if !inside_scripts(rel) {
                return Err(format!(
                    "replay_of.changed: `{rel}` is not a path inside the scripts directory"
                ));
            }
        }
    }
    Ok(())
}

/// The numbers of a test's input that the simulation takes as they are: finite, a tank with
/// its corners in order, a rock with a radius.
fn check_input(input: &super::inputs::Input) -> Result<(), String> {
    use super::inputs::Input;
    let finite = |field: &str, v: &[f32]| match v.iter().find(|x| !x.is_finite()) {
        Some(x) => Err(format!("{field}: {x} is not a finite number")),
        None => Ok(()),
    };
    match input {
        Input::Tank { min, max } => {
            finite("min", &min.to_array())?;
            finite("max", &max.to_array())?;
            if min.cmpge(*max).any() {
                return Err(format!("min: {min} must be below max {max} on every axis"));
            }
        }
        Input::Spawn {
            pos,
            heading,
            pitch,
            speed,
            ..
        } => {
            finite("pos", &pos.to_array())?;
            finite("heading", &[*heading, *pitch])?;
            finite("speed", &speed.iter().copied().collect::<Vec<_>>())?;
        }
        Input::FoodPhysics {
            sink_speed,
            lifetime,
        } => {
            finite("sink_speed", &[*sink_speed])?;
            finite("lifetime", &lifetime.iter().copied().collect::<Vec<_>>())?;
        }
        Input::Food { pos } => finite("pos", &pos.to_array())?,
        Input::Obstacle { pos, radius } => {
            finite("pos", &pos.to_array())?;
            if !(radius.is_finite() && *radius > 0.0) {
                return Err(format!("radius: {radius} is not a positive number"));
            }
        }
        Input::LodFocus { points } => {
            for p in points {
                finite("points", &p.to_array())?;
            }
        }
        Input::Motion { .. } | Input::SetBehavior { .. } => {}
    }
    Ok(())
}

fn parse_frames(mut b: &[u8]) -> Result<Vec<Vec<Pose>>, FramesError> {
    let mut frames = Vec::new();
    let word = |b: &[u8], i: usize| u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
    while !b.is_empty() {
        if b.len() < 4 {
            return Err(FramesError::NoCount(frames.len()));
        }
        let n = word(b, 0) as usize;
        let need = n.checked_mul(POSE_BYTES).and_then(|x| x.checked_add(4));
        let Some(need) = need.filter(|&need| need <= b.len()) else {
            return Err(FramesError::TooManyFish {
                frame: frames.len(),
                fish: n,
            });
        };
        let mut frame = Vec::with_capacity(n);
        for k in 0..n {
            let p = &b[4 + k * POSE_BYTES..4 + (k + 1) * POSE_BYTES];
            let f = |i: usize| f32::from_bits(word(p, i));
            frame.push(Pose {
                index: word(p, 0),
                generation: word(p, 4),
                pos: Vec3::new(f(8), f(12), f(16)),
                heading: f(20),
            });
        }
        frames.push(frame);
        b = &b[need..];
    }
    if frames.is_empty() {
        return Err(FramesError::None);
    }
    Ok(frames)
}

/// Reads the parts of a recording in order, naming what is missing when it is short.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
    path: &'a Path,
}

impl<'a> Reader<'a> {
    fn slice(&mut self, len: u64, what: &'static str) -> Result<&'a [u8], RunFileError> {
        let left = (self.bytes.len() - self.at) as u64;
        if len > left {
            return Err(RunFileError::Truncated {
                path: self.path.to_path_buf(),
                what,
                needed: len,
                left,
            });
        }
        let s = &self.bytes[self.at..self.at + len as usize];
        self.at += len as usize;
        Ok(s)
    }

    fn take<const N: usize>(&mut self, what: &'static str) -> Result<[u8; N], RunFileError> {
        let s = self.slice(N as u64, what)?;
        Ok(s.try_into().expect("slice has N bytes"))
    }
}

/// Every `.lua` file under `dir`, by path relative to it (with `/`), with its checksum and text.
pub fn read_scripts(dir: &Path) -> std::io::Result<BTreeMap<String, ScriptFile>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d)? {
            let p = entry?.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|e| e == "lua") {
                let text = std::fs::read_to_string(&p)?;
                let rel = p.strip_prefix(dir).unwrap_or(&p);
                let rel = rel
                    .components()
                    .map(|c| c.as_os_str().to_string_lossy())
                    .collect::<Vec<_>>()
                    .join("/");
                out.insert(
                    rel,
                    ScriptFile {
                        crc32: crc32fast::hash(text.as_bytes()),
                        text,
                    },
                );
            }
        }
    }
    Ok(out)
}

/// The script files that differ between two sets (changed, added or removed), sorted.
pub fn changed_scripts(
    a: &BTreeMap<String, ScriptFile>,
    b: &BTreeMap<String, ScriptFile>,
) -> Vec<String> {
    changed_keys(a, b)
}

/// The keys whose values differ between two maps, or that only one has, sorted.
pub fn changed_keys<V: PartialEq>(a: &BTreeMap<String, V>, b: &BTreeMap<String, V>) -> Vec<String> {
    let mut out: Vec<String> = a
        .iter()
        .filter(|(k, v)| b.get(*k) != Some(*v))
        .map(|(k, _)| k.clone())
        .chain(b.keys().filter(|k| !a.contains_key(*k)).cloned())
        .collect();
    out.sort();
    out.dedup();
    out
}
