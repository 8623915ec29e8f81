//! Checks of a glTF file that must run before the `gltf` crate validates it.
//!
//! The crate's validation indexes some arrays without checking the index first (gltf-json 1.4,
//! `mesh.rs`: the `POSITION` accessor of a primitive), so a file with an out-of-range accessor
//! index there panics instead of failing. [`check_indices`] rejects every out-of-range accessor
//! index a mesh holds, with an error naming the file and the field, before the crate looks.
//! [`check_glb_length`] names a cut-short `.glb` as truncated.

use std::path::Path;

use gltf::json::Root;
use gltf::json::validation::Checked;

use super::SkinError;

/// A `.glb` (it starts with the `glTF` magic) whose header announces more bytes than the file
/// has is truncated: say so, rather than let the parser report a missing chunk.
pub fn check_glb_length(bytes: &[u8], path: &Path) -> Result<(), SkinError> {
    if !bytes.starts_with(b"glTF") {
        return Ok(());
    }
    let invalid = |problem: String| SkinError::Invalid {
        path: path.to_path_buf(),
        problem,
    };
    let Some(header) = bytes.get(8..12) else {
        return Err(invalid(format!(
            "truncated GLB file: {} bytes, shorter than the 12-byte header",
            bytes.len()
        )));
    };
    let announced = u32::from_le_bytes([header[0], header[1], header[2], header[3]]) as usize;
    if announced < 12 {
        // The gltf crate subtracts the header's size from this length unchecked.
        return Err(invalid(format!(
            "invalid GLB header: it says the file is {announced} bytes, less than the header itself"
        )));
    }
    if announced > bytes.len() {
        return Err(invalid(format!(
            "truncated GLB file: the header says {announced} bytes, the file has {}",
            bytes.len()
        )));
    }
    Ok(())
}

/// Every accessor index held by a mesh primitive (attributes, indices, morph targets) is in
/// range.
pub fn check_indices(root: &Root, path: &Path) -> Result<(), SkinError> {
    let accessors = root.accessors.len();
    let check = |i: usize, field: &dyn Fn() -> String| {
        if i < accessors {
            Ok(())
        } else {
            Err(SkinError::Invalid {
                path: path.to_path_buf(),
                problem: format!(
                    "{} refers to accessor {i}, but the file has {accessors} accessors",
                    field()
                ),
            })
        }
    };
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let at = |what: String| format!("meshes[{m}].primitives[{p}].{what}");
            for (semantic, index) in &prim.attributes {
                let name = match semantic {
                    Checked::Valid(s) => s.to_string(),
                    Checked::Invalid => "(unknown)".to_owned(),
                };
                check(index.value(), &|| at(format!("attributes.{name}")))?;
            }
            if let Some(index) = &prim.indices {
                check(index.value(), &|| at("indices".to_owned()))?;
            }
            for (t, target) in prim.targets.iter().flatten().enumerate() {
                for (name, index) in [
                    ("POSITION", &target.positions),
                    ("NORMAL", &target.normals),
                    ("TANGENT", &target.tangents),
                ] {
                    if let Some(index) = index {
                        check(index.value(), &|| at(format!("targets[{t}].{name}")))?;
                    }
                }
            }
        }
    }
    Ok(())
}
