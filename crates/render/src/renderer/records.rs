//! The culling pass's per-fish records kept on the GPU between frames (issue 35): the renderer
//! keeps a copy of what the GPU buffer holds and, each frame, writes only the runs of records
//! that differ from it. A fish's record (palette offset, mesh, tint, selected) changes when fish
//! come or go, are selected, or change species; a fish that moves changes only its palette,
//! which the pose pass or the palette upload writes and the culling pass reads. When the
//! caller names its instances ([`crate::FrameInput::instances_revision`]) and they are the
//! last frame's, the fish's records are kept as they are and only the props' (after them) are
//! built and compared ([`RecordBuffer::sync_from`]): a steady frame costs nothing per fish.
//! Otherwise the CPU builds every record and compares them with its copy, a chunk at a time
//! (`memcmp`), and writes only what changed.

use bytemuck::Pod;

use super::GrowBuffer;

/// Records between two changed runs that are written along with them rather than starting a
/// new write (a write costs more than a few hundred bytes of copying).
const MERGE_GAP: usize = 16;

/// At most this many writes a frame: past it, one write from the first changed record to the
/// last.
const MAX_WRITES: usize = 64;

/// What [`RecordBuffer::sync_from`] did this frame.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(super) struct SyncStats {
    /// Records written to the GPU (changed ones, the few unchanged ones between changed runs
    /// written along with them, or all after the buffer grew).
    pub written: u32,
    /// `write_buffer` calls made.
    pub writes: u32,
}

/// Records compared at a time: one byte comparison (`memcmp`) per chunk, record by record
/// only inside a chunk that changed.
const CHUNK: usize = 256;

/// A GPU storage buffer of records and the CPU's copy of what it holds.
#[derive(Debug)]
pub(super) struct RecordBuffer<T> {
    pub gpu: GrowBuffer,
    /// What the first `mirror.len()` records of `gpu` hold.
    mirror: Vec<T>,
    /// The frame's records, filled through [`RecordBuffer::next`].
    next: Vec<T>,
    /// The frame's changed runs, `start..end` in records (scratch).
    runs: Vec<(usize, usize)>,
}

impl<T: Pod> RecordBuffer<T> {
    pub fn new(gpu: GrowBuffer) -> Self {
        Self {
            gpu,
            mirror: Vec::new(),
            next: Vec::new(),
            runs: Vec::new(),
        }
    }

    /// The frame's records (all, or those after the ones kept), empty: fill it, then
    /// [`RecordBuffer::sync_from`].
    pub fn next(&mut self) -> &mut Vec<T> {
        self.next.clear();
        &mut self.next
    }

    /// How many records the GPU buffer holds (as last synced).
    pub fn len(&self) -> usize {
        self.mirror.len()
    }

    /// Makes the GPU buffer hold its first `keep` records (at most [`RecordBuffer::len`],
    /// known not to have changed: they are not looked at) followed by the records put in
    /// [`RecordBuffer::next`], writing only the runs of those that differ from what it held;
    /// all of them when the buffer had to grow (a new buffer holds nothing: the kept records
    /// are written again from the CPU's copy). The cost follows the records in `next`, not the
    /// kept ones.
    pub fn sync_from(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        keep: usize,
    ) -> SyncStats {
        let keep = keep.min(self.mirror.len());
        let size = std::mem::size_of::<T>() as u64;
        let mut stats = SyncStats::default();
        if self
            .gpu
            .ensure(device, (keep + self.next.len()) as u64 * size)
        {
            // A new buffer: the kept records go in again, the rest as new.
            self.mirror.truncate(keep);
            if keep > 0 {
                queue.write_buffer(&self.gpu.buffer, 0, bytemuck::cast_slice(&self.mirror));
                stats.written += keep as u32;
                stats.writes += 1;
            }
        }
        changed_runs(&self.mirror[keep..], &self.next, &mut self.runs);
        for &(start, end) in &self.runs {
            queue.write_buffer(
                &self.gpu.buffer,
                (keep + start) as u64 * size,
                bytemuck::cast_slice(&self.next[start..end]),
            );
            stats.written += (end - start) as u32;
            stats.writes += 1;
        }
        if keep == 0 {
            // The GPU now holds what `next` holds; the old mirror is next frame's scratch.
            std::mem::swap(&mut self.mirror, &mut self.next);
        } else {
            self.mirror.truncate(keep);
            self.mirror.extend_from_slice(&self.next);
        }
        stats
    }
}

/// Puts into `runs` the ranges of `new` that differ from `old` (records compared bytewise, so a
/// NaN tint is not a change every frame) or that `old` does not have, neighbouring runs less
/// than [`MERGE_GAP`] apart merged, at most [`MAX_WRITES`] runs.
pub(super) fn changed_runs<T: Pod>(old: &[T], new: &[T], runs: &mut Vec<(usize, usize)>) {
    runs.clear();
    let mut push = |i: usize| match runs.last_mut() {
        Some(last) if i <= last.1 + MERGE_GAP => last.1 = i + 1,
        _ => runs.push((i, i + 1)),
    };
    let common = old.len().min(new.len());
    let mut start = 0;
    while start < common {
        let end = (start + CHUNK).min(common);
        if bytes(&old[start..end]) != bytes(&new[start..end]) {
            for i in start..end {
                if bytemuck::bytes_of(&old[i]) != bytemuck::bytes_of(&new[i]) {
                    push(i);
                }
            }
        }
        start = end;
    }
    if new.len() > common {
        push(common);
        if let Some(last) = runs.last_mut() {
            last.1 = new.len();
        }
    }
    if runs.len() > MAX_WRITES {
        let whole = (runs[0].0, runs[runs.len() - 1].1);
        runs.clear();
        runs.push(whole);
    }
}

/// A slice of records as its bytes.
fn bytes<T: Pod>(records: &[T]) -> &[u8] {
    bytemuck::cast_slice(records)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The runs from `mirror` to `new`, then `mirror` = `new` (as the GPU's copy).
    fn run(mirror: &mut Vec<[u32; 2]>, new: &[[u32; 2]]) -> Vec<(usize, usize)> {
        let mut runs = Vec::new();
        changed_runs(mirror, new, &mut runs);
        *mirror = new.to_vec();
        runs
    }

    fn records(n: u32) -> Vec<[u32; 2]> {
        (0..n).map(|i| [i, 7]).collect()
    }

    #[test]
    fn the_first_frame_writes_everything_and_a_steady_one_nothing() {
        let mut mirror = Vec::new();
        assert_eq!(run(&mut mirror, &records(1000)), [(0, 1000)]);
        assert_eq!(run(&mut mirror, &records(1000)), []);
    }

    #[test]
    fn only_the_changed_runs_are_written_and_near_ones_merge() {
        let mut mirror = records(1000);
        let mut new = records(1000);
        new[10][1] = 8;
        new[20][1] = 8; // within MERGE_GAP of 10: one write 10..21
        new[500][0] = 0;
        new[999][1] = 0;
        assert_eq!(run(&mut mirror, &new), [(10, 21), (500, 501), (999, 1000)]);
    }

    #[test]
    fn fish_that_come_and_go_write_only_the_new_tail() {
        let mut mirror = records(100);
        assert_eq!(run(&mut mirror, &records(150)), [(100, 150)]);
        assert_eq!(run(&mut mirror, &records(40)), []);
        let mut new = records(41);
        new[39][1] = 1;
        assert_eq!(run(&mut mirror, &new), [(39, 41)]);
    }

    #[test]
    fn too_many_runs_become_one_write() {
        let mut mirror = records(10_000);
        let mut new = records(10_000);
        for i in (0..10_000).step_by(100) {
            new[i][1] = 0;
        }
        assert_eq!(run(&mut mirror, &new), [(0, 9901)]);
    }

    #[test]
    fn a_nan_that_stays_is_no_change() {
        let mut runs = Vec::new();
        changed_runs(&[[f32::NAN, 1.0]], &[[f32::NAN, 1.0]], &mut runs);
        assert!(runs.is_empty());
    }
}
