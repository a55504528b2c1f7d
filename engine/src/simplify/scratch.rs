//! Scratch the legality checks reuse from one candidate to the next, owned by one part of the
//! state ([`Scratch`]), so that checking a collapse allocates nothing.

use glam::DVec3;

/// Marks, the fold check's new fan and the count of checks.
#[derive(Default)]
pub(crate) struct Scratch {
    /// Marks for the link condition.
    pub(crate) mark: Vec<u32>,
    pub(crate) mark_stamp: u32,
    /// The fold check's new fan: the two other corners and the new unit normal of each face.
    pub(crate) fan_scratch: Vec<([u32; 2], DVec3)>,
    /// For a ring vertex x, the index in `fan_scratch` of the face whose far edge starts at x
    /// (valid only where that face's far edge does start at x).
    pub(crate) spoke: Vec<u32>,
    /// Counts the calls of `State::is_legal`: a `Legal` token from the latest call (the one whose
    /// new face normals `fan_scratch` holds) carries the current count.
    pub(crate) check_id: u32,
}

impl Scratch {
    /// Scratch for a mesh of `vertex_count` vertices.
    pub(crate) fn new(vertex_count: usize) -> Scratch {
        Scratch { mark: vec![0; vertex_count], spoke: vec![0; vertex_count], ..Default::default() }
    }

    /// A fresh stamp for the scratch marks (every mark is older).
    pub(crate) fn next_stamp(&mut self) -> u32 {
        self.mark_stamp = self.mark_stamp.wrapping_add(2);
        if self.mark_stamp < 2 {
            self.mark.iter_mut().for_each(|m| *m = 0);
            self.mark_stamp = 2;
        }
        self.mark_stamp
    }
}
