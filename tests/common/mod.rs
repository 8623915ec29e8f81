//! Helpers shared by the asset tests.

use std::path::Path;
use std::process::Command;

/// Runs the Khronos validator (tools/validate-gltf.mjs) on `files`; panics with its report on
/// any error or warning, or if the validator is not installed.
pub fn validate(files: &[&Path]) {
    let tools = Path::new(env!("CARGO_MANIFEST_DIR")).join("tools");
    assert!(
        tools.join("node_modules/gltf-validator").is_dir(),
        "the glTF validator is not installed: run `npm ci` in tools/ (needs node and npm)"
    );
    let out = Command::new("node")
        .arg(tools.join("validate-gltf.mjs"))
        .args(files)
        .output()
        .expect("running node: install nodejs to run the glTF validator");
    let report = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "validator found errors or warnings:\n{report}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for f in files {
        assert!(
            report.contains(&format!("{}: 0 errors, 0 warnings", f.display())),
            "{report}"
        );
    }
}
