//! WGSL sources: embedded in the binary, reloadable from `shaders/` while tuning.
//!
//! Shader files are composed before compiling: `common.wgsl` is prepended to the scene shaders
//! and `skinning.wgsl` appended to the ones that skin, so the one skinning function serves the
//! fish vertex shader and the read-back compute pass alike.

use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Duration;

/// The shader files, by name, with the text compiled into the binary.
pub const EMBEDDED: [(&str, &str); 8] = [
    ("common.wgsl", include_str!("../../../shaders/common.wgsl")),
    (
        "skinning.wgsl",
        include_str!("../../../shaders/skinning.wgsl"),
    ),
    ("fish.wgsl", include_str!("../../../shaders/fish.wgsl")),
    (
        "environment.wgsl",
        include_str!("../../../shaders/environment.wgsl"),
    ),
    ("lines.wgsl", include_str!("../../../shaders/lines.wgsl")),
    (
        "skin_readback.wgsl",
        include_str!("../../../shaders/skin_readback.wgsl"),
    ),
    ("pose.wgsl", include_str!("../../../shaders/pose.wgsl")),
    ("cull.wgsl", include_str!("../../../shaders/cull.wgsl")),
];

/// The text of every shader file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ShaderSources {
    /// `(file name, text)` in the order of [`EMBEDDED`].
    pub files: Vec<(String, String)>,
}

impl Default for ShaderSources {
    fn default() -> Self {
        Self::embedded()
    }
}

impl ShaderSources {
    /// The sources compiled into the binary.
    pub fn embedded() -> Self {
        Self {
            files: EMBEDDED
                .iter()
                .map(|(n, t)| ((*n).to_owned(), (*t).to_owned()))
                .collect(),
        }
    }

    /// Reads every shader file from `dir`; a file that is missing keeps its embedded text.
    pub fn load_dir(dir: &Path) -> std::io::Result<Self> {
        let mut sources = Self::embedded();
        for (name, text) in &mut sources.files {
            let path = dir.join(name.as_str());
            match std::fs::read_to_string(&path) {
                Ok(t) => *text = t,
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(e) => {
                    return Err(std::io::Error::new(
                        e.kind(),
                        format!("{}: {e}", path.display()),
                    ));
                }
            }
        }
        Ok(sources)
    }

    /// The text of one file (empty if unknown).
    pub fn get(&self, name: &str) -> &str {
        self.files
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, t)| t.as_str())
            .unwrap_or("")
    }

    /// Where each file's lines sit in [`ShaderSources::compose`]'s output, for error messages,
    /// e.g. `common.wgsl = lines 1–60, fish.wgsl = lines 61–140`.
    pub fn line_map(&self, file: &str, with_common: bool, with_skinning: bool) -> String {
        let mut parts = Vec::new();
        let mut first = 1;
        let mut add = |name: &str| {
            let n = self.get(name).lines().count().max(1);
            parts.push(format!("{name} = lines {first}–{}", first + n - 1));
            first += n;
        };
        if with_common {
            add("common.wgsl");
        }
        add(file);
        if with_skinning {
            add("skinning.wgsl");
        }
        parts.join(", ")
    }

    /// `common.wgsl` + `file` (+ `skinning.wgsl` when `skinning`), ready to compile.
    pub fn compose(&self, file: &str, with_common: bool, with_skinning: bool) -> String {
        let mut s = String::new();
        let mut push = |text: &str| {
            s.push_str(text);
            if !text.ends_with('\n') {
                s.push('\n');
            }
        };
        if with_common {
            push(self.get("common.wgsl"));
        }
        push(self.get(file));
        if with_skinning {
            push(self.get("skinning.wgsl"));
        }
        s
    }
}

/// The `shaders/` directory of the source tree, if it exists (for hot reload).
pub fn source_dir() -> Option<PathBuf> {
    let candidates = [
        PathBuf::from("shaders"),
        shoal_core::source_root().join("shaders"),
    ];
    candidates
        .into_iter()
        .find(|p| p.join("fish.wgsl").is_file())
}

/// The shader directory could not be watched for changes (hot reload stays off).
#[derive(Debug, thiserror::Error)]
#[error("cannot watch {}: {source}", dir.display())]
pub struct WatchError {
    /// The directory.
    pub dir: PathBuf,
    /// The file watcher's error.
    pub source: notify_debouncer_full::notify::Error,
}

/// Watches a shader directory; [`ShaderWatcher::changed`] says whether a `.wgsl` file was saved
/// since the last call, [`ShaderWatcher::saved`] which.
pub struct ShaderWatcher {
    dir: PathBuf,
    /// The `.wgsl` files written, one message per batch of file events that has any.
    rx: mpsc::Receiver<Vec<PathBuf>>,
    _debouncer: notify_debouncer_full::Debouncer<
        notify_debouncer_full::notify::RecommendedWatcher,
        notify_debouncer_full::RecommendedCache,
    >,
}

impl std::fmt::Debug for ShaderWatcher {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ShaderWatcher")
            .field("dir", &self.dir)
            .finish()
    }
}

impl ShaderWatcher {
    /// Starts watching `dir` (non-recursive).
    pub fn new(dir: &Path) -> Result<Self, WatchError> {
        let failed = |source| WatchError {
            dir: dir.to_owned(),
            source,
        };
        let (tx, rx) = mpsc::channel();
        let mut debouncer = notify_debouncer_full::new_debouncer(
            Duration::from_millis(150),
            None,
            move |res: notify_debouncer_full::DebounceEventResult| {
                if let Ok(events) = res {
                    use notify_debouncer_full::notify::EventKind;
                    use notify_debouncer_full::notify::event::ModifyKind;
                    // Only writes count: reading the files to reload them must not re-trigger.
                    let written: Vec<PathBuf> = events
                        .iter()
                        .filter(|e| match e.kind {
                            EventKind::Create(_) | EventKind::Remove(_) => true,
                            EventKind::Modify(ModifyKind::Metadata(_)) => false,
                            EventKind::Modify(_) => true,
                            _ => false,
                        })
                        .flat_map(|e| e.paths.iter())
                        .filter(|p| p.extension().is_some_and(|x| x == "wgsl"))
                        .cloned()
                        .collect();
                    if !written.is_empty() {
                        let _ = tx.send(written);
                    }
                }
            },
        )
        .map_err(failed)?;
        debouncer
            .watch(
                dir,
                notify_debouncer_full::notify::RecursiveMode::NonRecursive,
            )
            .map_err(failed)?;
        Ok(Self {
            dir: dir.to_owned(),
            rx,
            _debouncer: debouncer,
        })
    }

    /// The watched directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// True if a `.wgsl` file changed since the last call (of this or [`ShaderWatcher::saved`]).
    pub fn changed(&self) -> bool {
        !self.saved().is_empty()
    }

    /// The `.wgsl` files written (saved, created or removed) since the last call, sorted, each
    /// once.
    pub fn saved(&self) -> Vec<PathBuf> {
        let mut files: Vec<PathBuf> = self.rx.try_iter().flatten().collect();
        files.sort();
        files.dedup();
        files
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_map_matches_the_composed_text() {
        let s = ShaderSources::embedded();
        let text = s.compose("fish.wgsl", true, true);
        let map = s.line_map("fish.wgsl", true, true);
        // Find fish.wgsl's first line in the composed text and check the map says so.
        let first_fish_line = s.get("fish.wgsl").lines().next().unwrap();
        let at = text.lines().position(|l| l == first_fish_line).unwrap() + 1;
        assert!(
            map.contains(&format!("fish.wgsl = lines {at}–")),
            "{map} (fish at {at})"
        );
        let total = text.lines().count();
        assert!(map.ends_with(&format!("–{total}")), "{map} (total {total})");
    }
}
