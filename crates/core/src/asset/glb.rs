//! A small deterministic GLB (binary glTF 2.0) writer: one buffer, tightly packed views, JSON
//! built as a `serde_json::Value` (sorted keys), so the same input gives the same bytes.

use glam::{Mat4, Vec3};
use serde_json::{Value, json};

/// `bufferView.target` for vertex attributes.
pub const ARRAY_BUFFER: u32 = 34962;
/// `bufferView.target` for indices.
pub const ELEMENT_ARRAY_BUFFER: u32 = 34963;

const FLOAT: u32 = 5126;
const UNSIGNED_BYTE: u32 = 5121;
const UNSIGNED_SHORT: u32 = 5123;
const UNSIGNED_INT: u32 = 5125;

/// Collects binary data as buffer views and accessors.
#[derive(Debug, Default)]
pub struct GlbBuilder {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl GlbBuilder {
    /// An empty builder.
    pub fn new() -> Self {
        Self::default()
    }

    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let mut v = json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()});
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        self.bin.extend_from_slice(bytes);
        self.views.push(v);
        self.views.len() - 1
    }

    fn accessor(&mut self, view: usize, component: u32, count: usize, ty: &str) -> usize {
        self.accessors.push(json!({
            "bufferView": view, "componentType": component, "count": count, "type": ty
        }));
        self.accessors.len() - 1
    }

    /// VEC3 float positions, with the min/max glTF requires for POSITION.
    pub fn positions(&mut self, data: &[Vec3]) -> usize {
        let bytes: Vec<u8> = data
            .iter()
            .flat_map(|v| v.to_array())
            .flat_map(f32::to_le_bytes)
            .collect();
        let view = self.view(&bytes, Some(ARRAY_BUFFER));
        let a = self.accessor(view, FLOAT, data.len(), "VEC3");
        let min = data
            .iter()
            .fold(Vec3::splat(f32::INFINITY), |m, v| m.min(*v));
        let max = data
            .iter()
            .fold(Vec3::splat(f32::NEG_INFINITY), |m, v| m.max(*v));
        self.accessors[a]["min"] = json!(min.to_array());
        self.accessors[a]["max"] = json!(max.to_array());
        a
    }

    /// VEC3 float (normals).
    pub fn vec3s(&mut self, data: &[Vec3]) -> usize {
        let bytes: Vec<u8> = data
            .iter()
            .flat_map(|v| v.to_array())
            .flat_map(f32::to_le_bytes)
            .collect();
        let view = self.view(&bytes, Some(ARRAY_BUFFER));
        self.accessor(view, FLOAT, data.len(), "VEC3")
    }

    /// VEC2 float (texture coordinates).
    pub fn vec2s(&mut self, data: &[[f32; 2]]) -> usize {
        self.float_vectors(data, "VEC2")
    }

    /// VEC4 float (weights, tangents, float colours).
    pub fn vec4s(&mut self, data: &[[f32; 4]]) -> usize {
        self.float_vectors(data, "VEC4")
    }

    /// A float vertex attribute of `N` components, little-endian, as accessor type `ty`.
    fn float_vectors<const N: usize>(&mut self, data: &[[f32; N]], ty: &str) -> usize {
        let bytes: Vec<u8> = data
            .iter()
            .flatten()
            .flat_map(|f| f.to_le_bytes())
            .collect();
        let view = self.view(&bytes, Some(ARRAY_BUFFER));
        self.accessor(view, FLOAT, data.len(), ty)
    }

    /// VEC4 normalized unsigned byte (vertex colours, linear).
    pub fn colors_u8(&mut self, data: &[[f32; 4]]) -> usize {
        let bytes: Vec<u8> = data
            .iter()
            .flatten()
            .map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8)
            .collect();
        let view = self.view(&bytes, Some(ARRAY_BUFFER));
        let a = self.accessor(view, UNSIGNED_BYTE, data.len(), "VEC4");
        self.accessors[a]["normalized"] = json!(true);
        a
    }

    /// VEC4 joint indices: unsigned byte when every index fits, else unsigned short.
    pub fn joints(&mut self, data: &[[u16; 4]]) -> usize {
        if data.iter().flatten().all(|&j| j <= 255) {
            let bytes: Vec<u8> = data.iter().flatten().map(|&j| j as u8).collect();
            let view = self.view(&bytes, Some(ARRAY_BUFFER));
            self.accessor(view, UNSIGNED_BYTE, data.len(), "VEC4")
        } else {
            let bytes: Vec<u8> = data
                .iter()
                .flatten()
                .flat_map(|j| j.to_le_bytes())
                .collect();
            let view = self.view(&bytes, Some(ARRAY_BUFFER));
            self.accessor(view, UNSIGNED_SHORT, data.len(), "VEC4")
        }
    }

    /// SCALAR indices: unsigned short when they fit, else unsigned int.
    pub fn indices(&mut self, data: &[u32]) -> usize {
        if data.iter().all(|&i| i <= 65535) {
            let bytes: Vec<u8> = data
                .iter()
                .flat_map(|&i| (i as u16).to_le_bytes())
                .collect();
            let view = self.view(&bytes, Some(ELEMENT_ARRAY_BUFFER));
            self.accessor(view, UNSIGNED_SHORT, data.len(), "SCALAR")
        } else {
            let bytes: Vec<u8> = data.iter().flat_map(|i| i.to_le_bytes()).collect();
            let view = self.view(&bytes, Some(ELEMENT_ARRAY_BUFFER));
            self.accessor(view, UNSIGNED_INT, data.len(), "SCALAR")
        }
    }

    /// MAT4 float (inverse bind matrices), column-major.
    pub fn mat4s(&mut self, data: &[Mat4]) -> usize {
        let bytes: Vec<u8> = data
            .iter()
            .flat_map(|m| m.to_cols_array())
            .flat_map(f32::to_le_bytes)
            .collect();
        let view = self.view(&bytes, None);
        self.accessor(view, FLOAT, data.len(), "MAT4")
    }

    /// Any accessor from raw little-endian bytes (`component_type` is the glTF enum, `ty` e.g.
    /// `"VEC4"`), as a vertex attribute view; for tests and unusual encodings.
    pub fn raw_accessor(
        &mut self,
        bytes: &[u8],
        component_type: u32,
        count: usize,
        ty: &str,
        normalized: bool,
    ) -> usize {
        let view = self.view(bytes, Some(ARRAY_BUFFER));
        let a = self.accessor(view, component_type, count, ty);
        if normalized {
            self.accessors[a]["normalized"] = json!(true);
        }
        a
    }

    /// SCALAR float keyframe times (an animation sampler's input), with the min/max glTF
    /// requires there; no buffer-view target (animation data is not a vertex attribute).
    pub fn key_times(&mut self, times: &[f32]) -> usize {
        let bytes: Vec<u8> = times.iter().flat_map(|t| t.to_le_bytes()).collect();
        let view = self.view(&bytes, None);
        let a = self.accessor(view, FLOAT, times.len(), "SCALAR");
        let min = times.iter().copied().fold(f32::INFINITY, f32::min);
        let max = times.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        self.accessors[a]["min"] = json!([min]);
        self.accessors[a]["max"] = json!([max]);
        a
    }

    /// Float keyframe values (an animation sampler's output): `data` holds `count` elements of
    /// `ty` (`"VEC3"`, `"VEC4"`…) back to back; no buffer-view target.
    pub fn key_values(&mut self, data: &[f32], count: usize, ty: &str) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|f| f.to_le_bytes()).collect();
        let view = self.view(&bytes, None);
        self.accessor(view, FLOAT, count, ty)
    }

    /// Bytes of binary data so far.
    pub fn bin_len(&self) -> usize {
        self.bin.len()
    }

    /// Raw bytes as a buffer view (an embedded image); returns the view index.
    pub fn image_view(&mut self, bytes: &[u8]) -> usize {
        self.view(bytes, None)
    }

    /// Finishes the document as a `.gltf` JSON text and its binary buffer, which the JSON
    /// names by `bin_uri` (a file beside it).
    pub fn finish_gltf(mut self, mut root: Value, bin_uri: &str) -> (Vec<u8>, Vec<u8>) {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        root["buffers"] = json!([{"byteLength": self.bin.len(), "uri": bin_uri}]);
        root["bufferViews"] = Value::Array(self.views);
        root["accessors"] = Value::Array(self.accessors);
        (serde_json::to_vec(&root).unwrap_or_default(), self.bin)
    }

    /// Finishes the file: fills `buffers`, `bufferViews` and `accessors` into `root` and writes
    /// the GLB container (JSON chunk padded with spaces, BIN chunk with zeros).
    pub fn finish(mut self, mut root: Value) -> Vec<u8> {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        root["buffers"] = json!([{"byteLength": self.bin.len()}]);
        root["bufferViews"] = Value::Array(self.views);
        root["accessors"] = Value::Array(self.accessors);
        let mut json_bytes = serde_json::to_vec(&root).unwrap_or_default();
        while !json_bytes.len().is_multiple_of(4) {
            json_bytes.push(b' ');
        }
        let total = 12 + 8 + json_bytes.len() + 8 + self.bin.len();
        let mut out = Vec::with_capacity(total);
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(json_bytes.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&json_bytes);
        out.extend_from_slice(&(self.bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&self.bin);
        out
    }
}
