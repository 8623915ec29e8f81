//! Another version of the scripts, for the split tank (`shoal run --split B`): a scripts
//! directory, or the scripts directory of a git revision written into a temporary directory.

use std::path::{Path, PathBuf};

/// Why version B of a split tank cannot be had; the message names `--split SPEC` and what to do.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct SplitSourceError(String);

fn fail<T>(message: String) -> Result<T, SplitSourceError> {
    Err(SplitSourceError(message))
}

/// Version B of a split tank (`--split DIR` or `--split git:REV`): its scripts directory and
/// label. A git revision's scripts are written into a temporary directory that lives as long as
/// this value.
#[derive(Debug)]
pub struct SplitSource {
    /// B's scripts directory.
    pub scripts: PathBuf,
    /// What B is, for the window's labels (`git:HEAD~1 (3f2a1c0)` or the directory).
    pub label: String,
    _temp: Option<tempfile::TempDir>,
}

/// Resolves `--split SPEC` against A's scripts directory `a_scripts`: a scripts directory, or
/// `git:REV` — the scripts directory of revision REV of the git repository `a_scripts` is in,
/// materialised into a temporary directory. A missing directory, a missing git, a scripts
/// directory outside a repository or an unknown revision is an error saying which.
pub fn split_source(spec: &str, a_scripts: &Path) -> Result<SplitSource, SplitSourceError> {
    let Some(rev) = spec.strip_prefix("git:") else {
        let dir = Path::new(spec);
        if !dir.is_dir() {
            return fail(format!(
                "--split {spec}: no such directory (B is a scripts directory holding behaviors/, \
                 species/ and scenes/, or git:REV for a revision of the repository the scripts \
                 are in)"
            ));
        }
        let dir = dir.canonicalize().unwrap_or_else(|_| dir.to_path_buf());
        return Ok(SplitSource {
            label: dir.display().to_string(),
            scripts: dir,
            _temp: None,
        });
    };
    if rev.is_empty() || rev.starts_with('-') {
        return fail(format!(
            "--split {spec}: expected git:REV with a revision, e.g. git:HEAD~1"
        ));
    }
    let top = git(spec, a_scripts, &["rev-parse", "--show-toplevel"]).map_err(|e| {
        SplitSourceError(format!(
            "{e}: the scripts directory {} must be inside a git repository for git:REV",
            a_scripts.display()
        ))
    })?;
    let top = PathBuf::from(String::from_utf8_lossy(&top).trim());
    let prefix = git(spec, a_scripts, &["rev-parse", "--show-prefix"])?;
    let prefix = String::from_utf8_lossy(&prefix).trim().to_owned();
    let commit = git(
        spec,
        &top,
        &[
            "rev-parse",
            "--verify",
            "--quiet",
            &format!("{rev}^{{commit}}"),
        ],
    )
    .map_err(|_| {
        SplitSourceError(format!(
            "--split {spec}: no revision `{rev}` in the git repository {}",
            top.display()
        ))
    })?;
    let commit = String::from_utf8_lossy(&commit).trim().to_owned();
    let path = if prefix.is_empty() { "." } else { &prefix };
    let listing = git(spec, &top, &["ls-tree", "-r", "-z", &commit, "--", path])?;
    let temp = tempfile::Builder::new()
        .prefix("shoal-split-")
        .tempdir()
        .map_err(|e| {
            SplitSourceError(format!(
                "--split {spec}: cannot make a temporary directory ({e})"
            ))
        })?;
    let mut files = 0;
    for entry in listing.split(|&b| b == 0).filter(|e| !e.is_empty()) {
        // `<mode> <type> <object>\t<path>`
        let entry = String::from_utf8_lossy(entry);
        let Some((meta, file)) = entry.split_once('\t') else {
            continue;
        };
        let mut meta = meta.split(' ');
        let (Some(_mode), Some("blob"), Some(object)) = (meta.next(), meta.next(), meta.next())
        else {
            continue;
        };
        let rel = file.strip_prefix(prefix.as_str()).unwrap_or(file);
        let out = temp.path().join(rel);
        let text = git(spec, &top, &["cat-file", "blob", object])?;
        if let Some(parent) = out.parent() {
            std::fs::create_dir_all(parent).map_err(|e| {
                SplitSourceError(format!(
                    "--split {spec}: cannot write {} ({e})",
                    parent.display()
                ))
            })?;
        }
        std::fs::write(&out, text).map_err(|e| {
            SplitSourceError(format!(
                "--split {spec}: cannot write {} ({e})",
                out.display()
            ))
        })?;
        files += 1;
    }
    if files == 0 {
        return fail(format!(
            "--split {spec}: the revision has no `{path}` directory (the scripts directory in the \
             repository {})",
            top.display()
        ));
    }
    let short = git(spec, &top, &["rev-parse", "--short", &commit])?;
    Ok(SplitSource {
        label: format!("git:{rev} ({})", String::from_utf8_lossy(&short).trim()),
        scripts: temp.path().to_path_buf(),
        _temp: Some(temp),
    })
}

/// Runs `git -C dir args…` and returns its stdout; an error names `--split SPEC` and says what
/// git said (or that git cannot be run).
fn git(spec: &str, dir: &Path, args: &[&str]) -> Result<Vec<u8>, SplitSourceError> {
    let out = std::process::Command::new("git")
        .arg("-C")
        .arg(dir)
        .args(args)
        .output()
        .map_err(|e| {
            SplitSourceError(format!(
                "--split {spec}: cannot run git ({e}); install git, or pass a scripts directory \
                 instead"
            ))
        })?;
    if !out.status.success() {
        let said = String::from_utf8_lossy(&out.stderr);
        let said = said.trim();
        return fail(format!(
            "--split {spec}: git {} failed{}",
            args.first().copied().unwrap_or_default(),
            if said.is_empty() {
                String::new()
            } else {
                format!(" ({said})")
            }
        ));
    }
    Ok(out.stdout)
}
