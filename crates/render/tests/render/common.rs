//! Helpers of the render tests: the core helpers, and the shipped porgy's mesh to upload.
#![allow(dead_code, unused_imports)]

#[path = "../../../core/tests/core/common.rs"]
mod core_common;
pub use core_common::*;

/// The porgy's mesh for [`shoal_render::Renderer::upload_mesh`].
pub trait UploadPorgy {
    /// The mesh to upload, labelled with the species name.
    fn upload(&self) -> shoal_render::MeshUpload<'_>;
}

impl UploadPorgy for PosedPorgy {
    fn upload(&self) -> shoal_render::MeshUpload<'_> {
        shoal_render::MeshUpload::from_skinned_mesh("black_porgy", &self.model.mesh)
    }
}
