//! The Lua scripts' static types (`shoal check [PATHS]`), checked by `emmylua_check` (a Rust,
//! LuaLS-compatible checker from crates.io) against the definitions in `scripts/types/`.
//!
//! shoal does not check types itself: it runs the checker with the shipped workspace config
//! (`.emmyrc.json` at the repository root) passed explicitly — the checker only looks for a
//! config in the first directory it is given, so `emmylua_check tests/behavior` on its own finds
//! none and reports every `test` and `shoal` as an undefined global. The scripts directory is
//! always part of the checked workspace (its `types/` hold the definitions, and `require` resolves
//! module names from it); only diagnostics in the files asked for are printed.

use std::ffi::OsString;
use std::fmt;
use std::path::{Path, PathBuf};
use std::process::Command;

use serde::Deserialize;

/// The checker's executable, looked up on `PATH`.
pub const CHECKER: &str = "emmylua_check";

/// The checker version the shipped scripts are clean under (what `.ci/run` installs).
pub const CHECKER_VERSION: &str = "0.25.1";

/// The workspace config shoal passes to the checker (it is also what editors read).
pub const CONFIG_FILE: &str = ".emmyrc.json";

/// What can go wrong running the checker (its diagnostics are not errors: they are the result).
#[derive(Debug, thiserror::Error)]
pub enum CheckError {
    /// A path given on the command line does not exist.
    #[error("{0}: no such file or directory")]
    NoSuchPath(PathBuf),
    /// A file given on the command line is not a Lua file.
    #[error("{0}: not a .lua file")]
    NotLua(PathBuf),
    /// `emmylua_check` is not on `PATH`.
    #[error(
        "`{CHECKER}` is not installed (not found on PATH). Install it with\n    cargo install \
         --locked {CHECKER}@{CHECKER_VERSION}\nand make sure ~/.cargo/bin is on your PATH."
    )]
    NotInstalled,
    /// The workspace config cannot be read or is not JSON.
    #[error("{path}: {why}")]
    Config {
        /// The config file.
        path: PathBuf,
        /// Why.
        why: String,
    },
    /// Neither the scripts' repository nor shoal's source tree has the workspace config.
    #[error("no {CONFIG_FILE} beside {0} or in shoal's source tree")]
    NoConfig(PathBuf),
    /// The checker could not be started.
    #[error("cannot run {program}: {source}")]
    Spawn {
        /// The executable.
        program: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The checker ran but wrote no report it could be read back from.
    #[error("{CHECKER} failed ({status}) without a report: {stderr}")]
    Failed {
        /// Its exit status.
        status: std::process::ExitStatus,
        /// What it printed on stderr.
        stderr: String,
    },
    /// The report is not the JSON the checker writes.
    #[error("cannot read {CHECKER}'s report: {0}")]
    Report(#[from] serde_json::Error),
    /// A temporary file for the report.
    #[error("cannot make a temporary file for the report: {0}")]
    Temp(#[source] std::io::Error),
}

/// How bad a diagnostic is (the Language Server Protocol's severities).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Severity {
    /// A type error, an undefined global, a syntax error.
    Error,
    /// Most type mismatches and possible nil accesses.
    Warning,
    /// Informational.
    Information,
    /// A hint (unused variables and the like).
    Hint,
}

impl Severity {
    fn from_lsp(n: Option<u8>) -> Severity {
        match n {
            Some(1) => Severity::Error,
            Some(2) | None => Severity::Warning,
            Some(3) => Severity::Information,
            _ => Severity::Hint,
        }
    }
}

impl fmt::Display for Severity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Severity::Error => "error",
            Severity::Warning => "warning",
            Severity::Information => "info",
            Severity::Hint => "hint",
        })
    }
}

/// One diagnostic, with 1-based line and column as editors and terminals link them.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Diagnostic {
    /// The file, relative to the working directory when it is under it.
    pub path: PathBuf,
    /// Line, from 1.
    pub line: u32,
    /// Column, from 1 (in UTF-16 code units, as the checker counts).
    pub column: u32,
    /// How bad.
    pub severity: Severity,
    /// The checker's diagnostic code (`param-type-mismatch`, `undefined-global`…).
    pub code: Option<String>,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for Diagnostic {
    /// `scripts/behaviors/x.lua:12:5: warning: message [code]`
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}:{}:{}: {}: {}",
            self.path.display(),
            self.line,
            self.column,
            self.severity,
            self.message.replace('\n', " ")
        )?;
        if let Some(code) = &self.code {
            write!(f, " [{code}]")?;
        }
        Ok(())
    }
}

/// The checker's JSON report: one entry per file.
#[derive(Debug, Deserialize)]
struct FileReport {
    file: PathBuf,
    #[serde(default)]
    diagnostics: Vec<LspDiagnostic>,
}

#[derive(Debug, Deserialize)]
struct LspDiagnostic {
    range: LspRange,
    severity: Option<u8>,
    code: Option<serde_json::Value>,
    message: String,
}

#[derive(Debug, Deserialize)]
struct LspRange {
    start: LspPosition,
}

#[derive(Debug, Deserialize)]
struct LspPosition {
    line: u32,
    character: u32,
}

/// What to check and with what.
#[derive(Debug, Clone)]
pub struct CheckPlan {
    /// The checker's executable.
    pub checker: PathBuf,
    /// The workspace config passed with `--config`.
    pub config: PathBuf,
    /// Directories given to the checker as workspace folders.
    pub workspaces: Vec<PathBuf>,
    /// Files and directories whose diagnostics are reported (canonical paths).
    pub targets: Vec<PathBuf>,
    /// The directory holding the scripts directory: the config's relative workspace paths
    /// (`scripts/types`, `scripts`) are meant from there.
    pub root: PathBuf,
}

/// Finds `program` in the directories of `path` (a `PATH` value).
pub fn find_on_path(program: &str, path: Option<OsString>) -> Option<PathBuf> {
    let path = path?;
    std::env::split_paths(&path)
        .map(|dir| dir.join(program))
        .find(|candidate| is_executable(candidate))
}

fn is_executable(path: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        path.metadata()
            .is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
    }
    #[cfg(not(unix))]
    {
        path.is_file() || path.with_extension("exe").is_file()
    }
}

/// The checker's version (`emmylua_check 0.25.1` → `0.25.1`), or None when it does not say.
pub fn checker_version(checker: &Path) -> Option<String> {
    let out = Command::new(checker).arg("--version").output().ok()?;
    let text = String::from_utf8_lossy(&out.stdout);
    text.split_whitespace().nth(1).map(str::to_owned)
}

/// The config for scripts in `scripts`: the one beside them (a repository's root), else shoal's
/// source tree's.
pub fn find_config(scripts: &Path) -> Result<PathBuf, CheckError> {
    let beside = scripts.parent().map(|p| p.join(CONFIG_FILE));
    let built = shoal_core::source_root().join(CONFIG_FILE);
    beside
        .into_iter()
        .chain([built])
        .find(|p| p.is_file())
        .ok_or_else(|| CheckError::NoConfig(scripts.to_path_buf()))
}

/// Builds the plan for `paths` (default: `scripts` and the `tests/behavior` beside it).
pub fn plan(
    paths: &[PathBuf],
    scripts: &Path,
    checker: PathBuf,
    config: PathBuf,
) -> Result<CheckPlan, CheckError> {
    let requested: Vec<PathBuf> = if paths.is_empty() {
        let tests = scripts.parent().map(|p| p.join("tests/behavior"));
        std::iter::once(scripts.to_path_buf())
            .chain(tests.filter(|t| t.is_dir()))
            .collect()
    } else {
        paths.to_vec()
    };
    let mut targets = Vec::new();
    let mut workspaces = Vec::new();
    for path in &requested {
        let canonical = path
            .canonicalize()
            .map_err(|_| CheckError::NoSuchPath(path.clone()))?;
        let folder = if canonical.is_dir() {
            canonical.clone()
        } else if canonical.extension().is_some_and(|x| x == "lua") {
            // The checker takes directories: check the file's and report only the file.
            canonical
                .parent()
                .map(Path::to_path_buf)
                .unwrap_or_else(|| canonical.clone())
        } else {
            return Err(CheckError::NotLua(path.clone()));
        };
        if !workspaces.contains(&folder) {
            workspaces.push(folder);
        }
        targets.push(canonical);
    }
    // The scripts directory always: its types/ and the modules `require` finds.
    let scripts = scripts
        .canonicalize()
        .unwrap_or_else(|_| scripts.to_path_buf());
    let root = scripts.parent().map(Path::to_path_buf).unwrap_or_default();
    if !workspaces.contains(&scripts) {
        workspaces.push(scripts);
    }
    Ok(CheckPlan {
        checker,
        config,
        workspaces,
        targets,
        root,
    })
}

/// `config` for scripts under `root`: None when the config sits there (its relative paths
/// are then meant from where the checker reads them); else the config's JSON with the relative
/// paths of `workspace.library` and `workspace.workspaceRoots` made absolute under `root`.
/// Without this, a copy of the scripts checked with shoal's own config also loads the source
/// tree's `scripts/`, and every class the copy declares is reported as a duplicate.
pub fn config_for_root(config: &Path, root: &Path) -> Result<Option<String>, CheckError> {
    let canonical = |p: &Path| p.canonicalize().unwrap_or_else(|_| p.to_path_buf());
    if config.parent().map(canonical) == Some(canonical(root)) {
        return Ok(None);
    }
    let text = std::fs::read_to_string(config).map_err(|source| CheckError::Config {
        path: config.to_path_buf(),
        why: source.to_string(),
    })?;
    let mut json: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| CheckError::Config {
            path: config.to_path_buf(),
            why: e.to_string(),
        })?;
    for key in ["library", "workspaceRoots"] {
        let Some(list) = json
            .pointer_mut(&format!("/workspace/{key}"))
            .and_then(serde_json::Value::as_array_mut)
        else {
            continue;
        };
        for entry in list {
            if let Some(rel) = entry.as_str().filter(|p| Path::new(p).is_relative()) {
                *entry = root.join(rel).to_string_lossy().into_owned().into();
            }
        }
    }
    Ok(Some(json.to_string()))
}

/// Runs the checker and returns the diagnostics in the plan's targets, sorted by file and
/// position, paths relative to `cwd` where they are under it.
pub fn check(plan: &CheckPlan, cwd: &Path) -> Result<Vec<Diagnostic>, CheckError> {
    let report = tempfile::Builder::new()
        .prefix("shoal-check-")
        .suffix(".json")
        .tempfile()
        .map_err(CheckError::Temp)?;
    let derived = match config_for_root(&plan.config, &plan.root)? {
        Some(json) => {
            let mut file = tempfile::Builder::new()
                .prefix("shoal-check-config-")
                .suffix(".json")
                .tempfile()
                .map_err(CheckError::Temp)?;
            std::io::Write::write_all(&mut file, json.as_bytes()).map_err(CheckError::Temp)?;
            Some(file)
        }
        None => None,
    };
    let config = derived.as_ref().map_or(plan.config.as_path(), |f| f.path());
    let out = Command::new(&plan.checker)
        .arg("--config")
        .arg(config)
        .args(["--output-format", "json", "--output"])
        .arg(report.path())
        .args(&plan.workspaces)
        .output()
        .map_err(|source| CheckError::Spawn {
            program: plan.checker.clone(),
            source,
        })?;
    let text = std::fs::read_to_string(report.path()).unwrap_or_default();
    if text.trim().is_empty() {
        // Exit status 1 only says there were errors; an empty report with it means it failed.
        return Err(CheckError::Failed {
            status: out.status,
            stderr: String::from_utf8_lossy(&out.stderr).trim().to_owned(),
        });
    }
    let files: Vec<FileReport> = serde_json::from_str(&text)?;
    Ok(diagnostics_in(files, &plan.targets, cwd))
}

fn diagnostics_in(files: Vec<FileReport>, targets: &[PathBuf], cwd: &Path) -> Vec<Diagnostic> {
    let cwd = cwd.canonicalize().unwrap_or_else(|_| cwd.to_path_buf());
    let mut found = Vec::new();
    for file in files {
        let canonical = file.file.canonicalize().unwrap_or(file.file.clone());
        if !targets.iter().any(|t| canonical.starts_with(t)) {
            continue;
        }
        let shown = canonical
            .strip_prefix(&cwd)
            .map(Path::to_path_buf)
            .unwrap_or(canonical.clone());
        for d in file.diagnostics {
            found.push(Diagnostic {
                path: shown.clone(),
                line: d.range.start.line + 1,
                column: d.range.start.character + 1,
                severity: Severity::from_lsp(d.severity),
                code: d.code.map(|c| match c {
                    serde_json::Value::String(s) => s,
                    other => other.to_string(),
                }),
                message: d.message,
            });
        }
    }
    found.sort_by(|a, b| (&a.path, a.line, a.column).cmp(&(&b.path, b.line, b.column)));
    found.dedup();
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn report_is_filtered_to_targets_and_made_one_based() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().canonicalize().unwrap();
        std::fs::create_dir_all(root.join("mine")).unwrap();
        std::fs::write(root.join("mine/a.lua"), "").unwrap();
        std::fs::write(root.join("other.lua"), "").unwrap();
        let json = format!(
            r#"[{{"file": "{a}", "diagnostics": [{{"range": {{"start": {{"line": 2, "character": 4}},
                "end": {{"line": 2, "character": 9}}}}, "severity": 2, "code": "param-type-mismatch",
                "message": "expected `number`\nbut found `string`"}}]}},
               {{"file": "{o}", "diagnostics": [{{"range": {{"start": {{"line": 0, "character": 0}},
                "end": {{"line": 0, "character": 1}}}}, "severity": 1, "message": "x"}}]}}]"#,
            a = root.join("mine/a.lua").display(),
            o = root.join("other.lua").display()
        );
        let files: Vec<FileReport> = serde_json::from_str(&json).unwrap();
        let found = diagnostics_in(files, &[root.join("mine")], &root);
        assert_eq!(found.len(), 1, "{found:?}");
        assert_eq!(
            found[0].to_string(),
            "mine/a.lua:3:5: warning: expected `number` but found `string` [param-type-mismatch]"
        );
    }

    #[test]
    fn missing_paths_and_non_lua_files_are_errors_naming_them() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("notes.txt"), "").unwrap();
        let error_of = |path: &PathBuf| {
            plan(
                std::slice::from_ref(path),
                dir.path(),
                "c".into(),
                "k".into(),
            )
            .unwrap_err()
            .to_string()
        };
        let missing = dir.path().join("nope");
        assert_eq!(
            error_of(&missing),
            format!("{}: no such file or directory", missing.display())
        );
        let txt = dir.path().join("notes.txt");
        assert_eq!(
            error_of(&txt),
            format!("{}: not a .lua file", txt.display())
        );
    }

    #[test]
    fn the_checker_is_found_only_on_path() {
        assert_eq!(find_on_path(CHECKER, None), None);
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(
            find_on_path(CHECKER, Some(dir.path().as_os_str().to_owned())),
            None
        );
    }
}
