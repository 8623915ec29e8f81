//! [`RawAccessor`]: a bounds-checked view of one accessor's bytes.

use std::path::{Path, PathBuf};

use glam::Vec3;
use gltf::accessor::{DataType, Dimensions};

use crate::skin::SkinError;

/// A bounds-checked view of one accessor's bytes.
pub(super) struct RawAccessor<'b> {
    bytes: &'b [u8],
    stride: usize,
    pub(super) count: usize,
    pub(super) dims: usize,
    pub(super) data_type: DataType,
    normalized: bool,
    path: PathBuf,
    what: String,
    index: usize,
}

impl<'b> RawAccessor<'b> {
    pub(super) fn new(
        acc: &gltf::Accessor,
        buffers: &[&'b [u8]],
        path: &Path,
        what: &str,
    ) -> Result<Self, SkinError> {
        let err = |problem: String| SkinError::Accessor {
            path: path.to_path_buf(),
            accessor: acc.index(),
            what: what.to_string(),
            problem,
        };
        if acc.sparse().is_some() {
            return Err(err("sparse accessors are not supported".into()));
        }
        let dims = match acc.dimensions() {
            Dimensions::Scalar => 1,
            Dimensions::Vec2 => 2,
            Dimensions::Vec3 => 3,
            Dimensions::Vec4 => 4,
            Dimensions::Mat2 => 4,
            Dimensions::Mat3 => 9,
            Dimensions::Mat4 => 16,
        };
        let data_type = acc.data_type();
        let elem = dims * data_type.size();
        let count = acc.count();
        let Some(view) = acc.view() else {
            // No buffer view and no sparse data: all zeros per the specification.
            return Ok(Self {
                bytes: &[],
                stride: 0,
                count,
                dims,
                data_type,
                normalized: acc.normalized(),
                path: path.to_path_buf(),
                what: what.to_string(),
                index: acc.index(),
            });
        };
        if matches!(acc.dimensions(), Dimensions::Mat2 | Dimensions::Mat3) && data_type.size() < 4 {
            return Err(err(
                "padded MAT2/MAT3 of bytes or shorts are not supported".into()
            ));
        }
        let buffer = buffers
            .get(view.buffer().index())
            .ok_or_else(|| err(format!("buffer {} does not exist", view.buffer().index())))?;
        let view_end = view
            .offset()
            .checked_add(view.length())
            .filter(|&e| e <= buffer.len())
            .ok_or_else(|| {
                err(format!(
                    "buffer view {} (offset {}, length {}) runs past its buffer of {} bytes",
                    view.index(),
                    view.offset(),
                    view.length(),
                    buffer.len()
                ))
            })?;
        let view_bytes = &buffer[view.offset()..view_end];
        let stride = view.stride().unwrap_or(elem);
        if stride < elem {
            return Err(err(format!(
                "byteStride {stride} is less than the element size {elem}"
            )));
        }
        let needed = if count == 0 {
            Some(0)
        } else {
            (count - 1)
                .checked_mul(stride)
                .and_then(|x| x.checked_add(elem))
                .and_then(|x| x.checked_add(acc.offset()))
        };
        match needed {
            Some(end) if end <= view_bytes.len() => {}
            _ => {
                return Err(err(format!(
                    "{count} elements of {elem} bytes (stride {stride}, offset {}) run past buffer view {} of {} bytes",
                    acc.offset(),
                    view.index(),
                    view_bytes.len()
                )));
            }
        }
        Ok(Self {
            bytes: &view_bytes[acc.offset().min(view_bytes.len())..],
            stride,
            count,
            dims,
            data_type,
            normalized: acc.normalized(),
            path: path.to_path_buf(),
            what: what.to_string(),
            index: acc.index(),
        })
    }

    pub(super) fn error(&self, problem: &str) -> SkinError {
        SkinError::Accessor {
            path: self.path.clone(),
            accessor: self.index,
            what: self.what.clone(),
            problem: problem.to_string(),
        }
    }

    /// Component `c` of element `i` as stored (bounds were checked in `new`); 0 when there
    /// is no buffer view.
    fn component_bits(&self, i: usize, c: usize) -> u32 {
        if self.bytes.is_empty() {
            return 0;
        }
        let size = self.data_type.size();
        let at = i * self.stride + c * size;
        let b = &self.bytes[at..at + size];
        match size {
            1 => u32::from(b[0]),
            2 => u32::from(u16::from_le_bytes([b[0], b[1]])),
            _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
        }
    }

    /// Component as a float: normalized integers map to [0, 1] or [−1, 1].
    pub(super) fn float(&self, i: usize, c: usize) -> f32 {
        let bits = self.component_bits(i, c);
        match self.data_type {
            DataType::F32 => f32::from_bits(bits),
            DataType::U8 if self.normalized => bits as f32 / 255.0,
            DataType::U16 if self.normalized => bits as f32 / 65535.0,
            DataType::I8 if self.normalized => (f32::from(bits as u8 as i8) / 127.0).max(-1.0),
            DataType::I16 if self.normalized => (f32::from(bits as u16 as i16) / 32767.0).max(-1.0),
            DataType::I8 => f32::from(bits as u8 as i8),
            DataType::I16 => f32::from(bits as u16 as i16),
            DataType::U8 | DataType::U16 | DataType::U32 => bits as f32,
        }
    }

    pub(super) fn uint(&self, i: usize, c: usize) -> u32 {
        self.component_bits(i, c)
    }

    pub(super) fn vec3s(&self) -> Result<Vec<Vec3>, SkinError> {
        if self.dims != 3 {
            return Err(self.error("must be VEC3"));
        }
        let mut out = Vec::with_capacity(self.count);
        for i in 0..self.count {
            let v = Vec3::new(self.float(i, 0), self.float(i, 1), self.float(i, 2));
            if !v.is_finite() {
                return Err(self.error(&format!("element {i} is not finite: {v}")));
            }
            out.push(v);
        }
        Ok(out)
    }
}
