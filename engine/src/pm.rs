//! Progressive meshes: a base mesh M0 plus an ordered list of vertex splits (Hoppe 1996).
//!
//! Numbering: M0 uses vertices `0..n0` and faces `0..f0`; split `j` (0-based) adds vertex
//! `n0 + j` and its one or two faces right after the faces of level `j`. So the mesh at level `l`
//! is always a prefix: the first `n0 + l` vertices and the first `face_counts[l]` faces.
//!
//! A split re-creates vertex `vt` next to `vs`:
//! ```text
//!          vl                        vl
//!          |                        /  \
//!          |                       /    \
//!   ...---vs---...     ==>  ...---vs----vt---...
//!          |                       \    /
//!          |                        \  /
//!          vr                        vr
//! ```
//! The faces around `vs` from the one with half-edge `vs→vr` counter-clockwise to the one whose
//! last corner is `vl` move to `vt`; the faces `(vs, vt, vl)` and `(vt, vs, vr)` are added (either
//! may be absent on a boundary). A split that undoes the closing of a triangular hole (a boundary
//! loop of three edges, which the simplifier's last collapse of it closes) names the hole's third
//! corner as `vl` or `vr` ([`VertexSplit::hole`]): the faces move as above, and no face is added
//! on that side, so the hole `(vs, vt, ·)` opens again. `vs` returns to its position before the
//! collapse, `vt` gets its own. Positions are stored as the input's `f32` values, so refining all
//! the way gives back the input bit for bit.

use serde::Serialize;

use crate::error::MeshError;
use crate::mesh::{CornerAttributes, Mesh};

/// The per-corner attributes of a progressive mesh (Hoppe's wedges, as references): every value
/// is one of the input's corners, so a level's corners are indices into `values`. Kept in memory
/// by the simplifier's progressive mesh and carried by the `.pm` file (versions 2 and 3).
#[derive(Debug, Clone, PartialEq)]
pub struct PmAttributes {
    /// The values; the indices below point into them (one entry per value, every array present
    /// of the same length).
    pub values: CornerAttributes,
    /// The base mesh's corners (3 per face, in its faces' corner order).
    pub base: Vec<[u32; 3]>,
    /// Per split, in refinement order.
    pub splits: Vec<SplitAttributes>,
}

/// What one split restores: see [`PmAttributes`].
#[derive(Debug, Clone, PartialEq)]
pub struct SplitAttributes {
    /// The corners of the split's new faces, in the order `(vs, vt, vl)`, `(vt, vs, vr)` of those
    /// present (unused entries are zero).
    pub new_faces: [[u32; 3]; 2],
    /// The faces that move from `vs` to `vt`, with the value their corner at `vt` takes.
    pub moved: Vec<(u32, u32)>,
}

impl PmAttributes {
    /// Number of values.
    pub fn value_count(&self) -> usize {
        self.values.value_count()
    }
}

impl PmAttributes {
    fn from_log(
        a: AttributeLog<'_>,
        final_triangles: &[[u32; 3]],
        face_alive: &[bool],
        log: &[CollapseRecord],
        face_counts: &[u32],
    ) -> PmAttributes {
        // A removed face keeps the vertices it had when it was removed (the simplifier tracks
        // its triangles whenever it carries attributes).
        let corner = |f: u32, v: u32| -> u32 {
            let k = final_triangles[f as usize].iter().position(|&x| x == v).expect("the face has the vertex");
            a.corner_source[3 * f as usize + k]
        };
        let mut pm_face = vec![NO_VERTEX; final_triangles.len()];
        let mut base = Vec::new();
        for f in (0..final_triangles.len()).filter(|&f| face_alive[f]) {
            pm_face[f] = base.len() as u32;
            base.push([0, 1, 2].map(|k| a.corner_source[3 * f + k]));
        }
        let mut splits = Vec::with_capacity(log.len());
        for (j, r) in log.iter().enumerate().rev() {
            let mut id = face_counts[log.len() - 1 - j];
            let mut new_faces = [[0; 3]; 2];
            let mut slot = 0;
            if r.left != NO_VERTEX {
                new_faces[slot] =
                    [corner(r.left_face, r.survivor), corner(r.left_face, r.removed), corner(r.left_face, r.left)];
                pm_face[r.left_face as usize] = id;
                (id, slot) = (id + 1, slot + 1);
            }
            if r.right != NO_VERTEX {
                new_faces[slot] =
                    [corner(r.right_face, r.removed), corner(r.right_face, r.survivor), corner(r.right_face, r.right)];
                pm_face[r.right_face as usize] = id;
            }
            let start = if j == 0 { 0 } else { a.journal_ends[j - 1] as usize };
            let moved = a.journal[start..a.journal_ends[j] as usize]
                .iter()
                .map(|&(f, old)| (pm_face[f as usize], old))
                .collect();
            splits.push(SplitAttributes { new_faces, moved });
        }
        PmAttributes { values: a.values.clone(), base, splits }
    }
}

/// What the simplifier hands over to build [`PmAttributes`]: the input's values, each face's
/// corners at the end of the run (for a removed face: when it was removed), and the journal of
/// the values that each collapse replaced.
pub(crate) struct AttributeLog<'a> {
    pub values: &'a CornerAttributes,
    pub corner_source: &'a [u32],
    pub journal: &'a [(u32, u32)],
    pub journal_ends: &'a [u32],
}

/// Marks an absent `vl` or `vr` (the collapsed edge was on a boundary): [`crate::mesh::NONE`].
pub use crate::mesh::NONE as NO_VERTEX;

/// One edge collapse as the simplifier logs it (indices of the simplifier's prepared mesh).
#[derive(Debug, Clone, Copy)]
pub(crate) struct CollapseRecord {
    pub survivor: u32,
    pub removed: u32,
    pub left: u32,
    pub right: u32,
    pub left_face: u32,
    pub right_face: u32,
    /// The third corner of the triangular hole the collapse closed (on the side without a face),
    /// or [`NO_VERTEX`].
    pub hole: u32,
    pub survivor_position: [f32; 3],
    pub removed_position: [f32; 3],
    pub collapsed_position: [f32; 3],
    pub error: f32,
}

impl CollapseRecord {
    /// The third corners of the split that undoes this collapse, `vl` and `vr` (in the
    /// simplifier's numbering), and which of them is a closed hole's corner: that corner takes the
    /// side without a face.
    fn split_corners(&self) -> (u32, u32, Hole) {
        match (self.hole, self.left) {
            (NO_VERTEX, _) => (self.left, self.right, Hole::None),
            (corner, NO_VERTEX) => (corner, self.right, Hole::Left),
            (corner, _) => (self.left, corner, Hole::Right),
        }
    }
}

/// Which of a split's `vl` and `vr` is the third corner of a triangular hole that the split opens
/// again rather than of a face it adds (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Hole {
    /// Both name the faces they add (or are absent).
    #[default]
    None,
    /// `vl` names the hole's corner: no face `(vs, vt, vl)`.
    Left,
    /// `vr` names the hole's corner: no face `(vt, vs, vr)`.
    Right,
}

/// Whether a split with these third corners adds its face `(vs, vt, vl)` and its face
/// `(vt, vs, vr)`.
fn sides_added(vl: u32, vr: u32, hole: Hole) -> [bool; 2] {
    [vl != NO_VERTEX && hole != Hole::Left, vr != NO_VERTEX && hole != Hole::Right]
}

/// Number of faces a split with these third corners adds.
pub(crate) fn faces_added(vl: u32, vr: u32, hole: Hole) -> usize {
    sides_added(vl, vr, hole).into_iter().filter(|&added| added).count()
}

/// One vertex split (the inverse of one edge collapse).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct VertexSplit {
    /// The vertex that splits.
    pub vs: u32,
    /// Third vertex of the added face `(vs, vt, vl)`, or [`NO_VERTEX`].
    pub vl: u32,
    /// Third vertex of the added face `(vt, vs, vr)`, or [`NO_VERTEX`].
    pub vr: u32,
    /// Whether `vl` or `vr` names a hole's corner instead of a face's.
    pub hole: Hole,
    /// Position of the new vertex `vt`.
    pub new_position: [f32; 3],
    /// Position of `vs` after the split.
    pub split_position: [f32; 3],
    /// Position of `vs` before the split (where the collapse had put it).
    pub collapsed_position: [f32; 3],
    /// Largest collapse error estimate up to and including this split's collapse, paper units of
    /// the original mesh. Non-increasing along the split order: refine until it drops below a
    /// tolerance to stop at an error rather than at a count.
    pub error: f32,
}

impl VertexSplit {
    /// Whether the split moves `vs` (false for endpoint placement).
    pub fn moves_vs(&self) -> bool {
        self.split_position.map(f32::to_bits) != self.collapsed_position.map(f32::to_bits)
    }

    /// Number of faces the split adds.
    pub fn added_faces(&self) -> usize {
        faces_added(self.vl, self.vr, self.hole)
    }
}

/// A vertex split as a file or a stream carries it: `vs`'s position before the split is not sent,
/// it is whatever the previous splits left there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreamedSplit {
    /// The vertex that splits.
    pub vs: u32,
    /// See [`VertexSplit::vl`].
    pub vl: u32,
    /// See [`VertexSplit::vr`].
    pub vr: u32,
    /// See [`VertexSplit::hole`].
    pub hole: Hole,
    /// Position of the new vertex.
    pub new_position: [f32; 3],
    /// New position of `vs`, or `None` when it does not move.
    pub split_position: Option<[f32; 3]>,
    /// See [`VertexSplit::error`].
    pub error: f32,
}

/// A base mesh and the vertex splits that refine it back to the original.
#[derive(Debug, Clone, PartialEq)]
pub struct ProgressiveMesh {
    base: Mesh,
    splits: Vec<VertexSplit>,
    /// Faces at each level `0..=splits.len()`.
    face_counts: Vec<u32>,
    /// Input vertex of each vertex (when built by the simplifier).
    input_vertex: Option<Vec<u32>>,
    /// Per-corner attributes, when the input had them (built by the simplifier only).
    attributes: Option<PmAttributes>,
}

impl ProgressiveMesh {
    /// Builds the progressive mesh from the simplifier's collapse log, which it takes over: the
    /// vertex splits are collected from the records in place (`Vec`'s in-place collection, a split
    /// being smaller than a record), so the run's largest array is not held twice.
    pub(crate) fn from_log(
        prepared: &Mesh,
        input_vertex: &[u32],
        final_position: impl Fn(u32) -> [f32; 3],
        final_triangles: &[[u32; 3]],
        face_alive: &[bool],
        log: Vec<CollapseRecord>,
        attribute_log: Option<AttributeLog<'_>>,
    ) -> ProgressiveMesh {
        let n = prepared.vertex_count();
        let mut removed = vec![false; n];
        for r in &log {
            removed[r.removed as usize] = true;
        }
        let mut vertex_map = vec![NO_VERTEX; n];
        let mut order: Vec<u32> = Vec::with_capacity(n);
        for v in 0..n {
            if !removed[v] {
                vertex_map[v] = order.len() as u32;
                order.push(v as u32);
            }
        }
        let base_vertices = order.len();
        for r in log.iter().rev() {
            vertex_map[r.removed as usize] = order.len() as u32;
            order.push(r.removed);
        }
        let map = |v: u32| if v == NO_VERTEX { NO_VERTEX } else { vertex_map[v as usize] };
        let base_positions: Vec<[f32; 3]> = order[..base_vertices].iter().map(|&v| final_position(v)).collect();
        let base_triangles: Vec<[u32; 3]> = (0..final_triangles.len())
            .filter(|&f| face_alive[f])
            .map(|f| final_triangles[f].map(|v| vertex_map[v as usize]))
            .collect();
        let mut face_counts = Vec::with_capacity(log.len() + 1);
        face_counts.push(base_triangles.len() as u32);
        for r in log.iter().rev() {
            let (left, right, hole) = r.split_corners();
            face_counts.push(face_counts.last().expect("non-empty") + faces_added(left, right, hole) as u32);
        }
        let attributes =
            attribute_log.map(|a| PmAttributes::from_log(a, final_triangles, face_alive, &log, &face_counts));
        // In the records' order, then turned round: the last collapse is the first split.
        let mut splits: Vec<VertexSplit> = log
            .into_iter()
            .map(|r| {
                let (left, right, hole) = r.split_corners();
                VertexSplit {
                    vs: map(r.survivor),
                    vl: map(left),
                    vr: map(right),
                    hole,
                    new_position: r.removed_position,
                    split_position: r.survivor_position,
                    collapsed_position: r.collapsed_position,
                    error: r.error,
                }
            })
            .collect();
        splits.reverse();
        let input_vertex = order.iter().map(|&v| input_vertex[v as usize]).collect();
        let mut base = Mesh { positions: base_positions, triangles: base_triangles, corners: Default::default() };
        if let Some(attributes) = &attributes {
            base.corners = attributes.values.pick(attributes.base.iter().flatten().map(|&k| k as usize));
        }
        ProgressiveMesh { base, splits, face_counts, input_vertex: Some(input_vertex), attributes }
    }

    /// Assembles a progressive mesh from parts read elsewhere (a file, a stream), checking it by
    /// replaying every split: a corrupt sequence is refused here, so later refinement cannot fail.
    pub fn from_parts(base: Mesh, splits: Vec<VertexSplit>) -> Result<ProgressiveMesh, MeshError> {
        base.check()?;
        let mut face_counts = Vec::with_capacity(splits.len() + 1);
        face_counts.push(base.face_count() as u32);
        for s in &splits {
            face_counts.push(face_counts.last().expect("non-empty") + s.added_faces() as u32);
        }
        let pm = ProgressiveMesh { base, splits, face_counts, input_vertex: None, attributes: None };
        let mut cursor = LodCursor::new(&pm);
        cursor.seek_level(pm.splits.len())?;
        Ok(pm)
    }

    /// Assembles a progressive mesh from streamed splits, replaying positions to recover where
    /// each `vs` sat before its split, then checking it as [`ProgressiveMesh::from_parts`] does.
    pub fn from_stream(
        base: Mesh,
        splits: impl IntoIterator<Item = StreamedSplit>,
    ) -> Result<ProgressiveMesh, MeshError> {
        let mut current = base.positions.clone();
        let mut out = Vec::new();
        for (j, s) in splits.into_iter().enumerate() {
            let collapsed_position = *current.get(s.vs as usize).ok_or_else(|| MeshError::Parse {
                path: "<progressive mesh>".into(),
                location: format!("split {j}"),
                reason: format!("vs {} out of range ({} vertices)", s.vs, current.len()),
            })?;
            let split_position = s.split_position.unwrap_or(collapsed_position);
            current[s.vs as usize] = split_position;
            current.push(s.new_position);
            out.push(VertexSplit {
                vs: s.vs,
                vl: s.vl,
                vr: s.vr,
                hole: s.hole,
                new_position: s.new_position,
                split_position,
                collapsed_position,
                error: s.error,
            });
        }
        ProgressiveMesh::from_parts(base, out)
    }

    /// The coarsest mesh M0.
    pub fn base(&self) -> &Mesh {
        &self.base
    }

    /// The vertex splits, in refinement order.
    pub fn splits(&self) -> &[VertexSplit] {
        &self.splits
    }

    /// Number of levels above the base (= number of splits).
    pub fn levels(&self) -> usize {
        self.splits.len()
    }

    /// Faces of the mesh at `level` (0 = base).
    pub fn faces_at_level(&self, level: usize) -> usize {
        self.face_counts[level.min(self.splits.len())] as usize
    }

    /// Vertices of the mesh at `level`.
    pub fn vertices_at_level(&self, level: usize) -> usize {
        self.base.vertex_count() + level.min(self.splits.len())
    }

    /// For each vertex (in this numbering), its index in the mesh given to the simplifier; `None`
    /// when read from a file.
    pub fn input_vertex(&self) -> Option<&[u32]> {
        self.input_vertex.as_deref()
    }

    /// The finest level whose face count does not exceed `faces` (the base if even it has more).
    pub fn level_for_faces(&self, faces: usize) -> usize {
        self.face_counts.partition_point(|&c| c as usize <= faces).saturating_sub(1)
    }

    /// The mesh with at most `faces` faces, as close to it as the levels allow.
    pub fn at_faces(&self, faces: usize) -> Mesh {
        self.at_level(self.level_for_faces(faces))
    }

    /// The mesh with `vertices` vertices (clamped to the base and the original).
    pub fn at_vertices(&self, vertices: usize) -> Mesh {
        self.at_level(vertices.saturating_sub(self.base.vertex_count()))
    }

    /// The mesh at `level` (clamped to the number of splits).
    pub fn at_level(&self, level: usize) -> Mesh {
        let mut cursor = LodCursor::new(self);
        cursor.seek_level(level).expect("a ProgressiveMesh is validated when built");
        cursor.mesh()
    }

    /// A cursor for moving between levels incrementally.
    pub fn cursor(&self) -> LodCursor<'_> {
        LodCursor::new(self)
    }

    /// Whether the levels carry per-corner attributes.
    pub fn has_attributes(&self) -> bool {
        self.attributes.is_some()
    }

    /// The per-corner attributes of the levels, when there are any.
    pub fn attributes(&self) -> Option<&PmAttributes> {
        self.attributes.as_ref()
    }

    /// Adds per-corner attributes (read from a file), checked against the splits: every index in
    /// range, every moved face present at its level. The base mesh takes its values.
    pub fn with_attributes(mut self, attributes: PmAttributes) -> Result<ProgressiveMesh, MeshError> {
        let bad =
            |location: String, reason: String| MeshError::Parse { path: "<progressive mesh>".into(), location, reason };
        let count = attributes.value_count() as u32;
        let out_of_range = |ids: &[u32]| ids.iter().find(|&&k| k >= count).copied();
        attributes.values.check_skin(count as usize).map_err(|e| bad("attributes".into(), e.to_string()))?;
        if attributes.base.len() != self.base.face_count() || attributes.splits.len() != self.splits.len() {
            return Err(bad("attributes".into(), "do not match the base faces and the splits".into()));
        }
        if let Some(k) = out_of_range(attributes.base.as_flattened()) {
            return Err(bad("base attributes".into(), format!("value {k} out of range ({count} values)")));
        }
        for (j, (split, a)) in self.splits.iter().zip(&attributes.splits).enumerate() {
            if let Some(k) = out_of_range(a.new_faces[..split.added_faces()].as_flattened()) {
                return Err(bad(format!("split {j} attributes"), format!("value {k} out of range ({count} values)")));
            }
            let faces = self.face_counts[j];
            if let Some(&(f, k)) = a.moved.iter().find(|&&(f, k)| f >= faces || k >= count) {
                return Err(bad(
                    format!("split {j} attributes"),
                    format!("moved face {f} / value {k} out of range ({faces} faces, {count} values)"),
                ));
            }
        }
        self.base.corners = attributes.values.pick(attributes.base.iter().flatten().map(|&k| k as usize));
        self.attributes = Some(attributes);
        Ok(self)
    }
}

/// The faces of a progressive mesh as splits are applied and undone: each face's vertices and,
/// per vertex, the faces around it. [`LodCursor`] and the `.pm` codec replay splits with it.
#[derive(Debug, Clone)]
pub(crate) struct Fans {
    pub triangles: Vec<[u32; 3]>,
    pub vertex_faces: Vec<Vec<u32>>,
    /// The faces that the last [`Fans::split`] moved from `vs` to `vt`, in walk order.
    pub moved: Vec<u32>,
}

impl Fans {
    /// The base mesh's faces, with room for `total_vertices` and `total_faces`.
    pub fn new(base: &[[u32; 3]], total_vertices: usize, total_faces: usize) -> Fans {
        let mut triangles = Vec::with_capacity(total_faces.max(base.len()));
        triangles.extend_from_slice(base);
        triangles.resize(total_faces.max(base.len()), [0; 3]);
        let mut vertex_faces = vec![Vec::new(); total_vertices];
        for (f, t) in base.iter().enumerate() {
            for &v in t {
                vertex_faces[v as usize].push(f as u32);
            }
        }
        Fans { triangles, vertex_faces, moved: Vec::new() }
    }

    /// Face around `v` whose corners, rotated to start at `v`, satisfy `pred`.
    fn find_face(&self, v: u32, pred: impl Fn([u32; 3]) -> bool) -> Option<u32> {
        self.vertex_faces[v as usize].iter().copied().find(|&f| pred(rotate_to(self.triangles[f as usize], v)))
    }

    /// The distinct vertices that share a face with `v`, in increasing order.
    pub fn neighbours(&self, v: u32) -> Vec<u32> {
        let mut ring: Vec<u32> = self.vertex_faces[v as usize]
            .iter()
            .flat_map(|&f| self.triangles[f as usize])
            .filter(|&x| x != v)
            .collect();
        ring.sort_unstable();
        ring.dedup();
        ring
    }

    /// Applies the split of `vs` with `vl` and `vr` (or [`NO_VERTEX`]; `hole` names the one that
    /// is a hole's corner, if any) that adds vertex `vt` (the number of vertices before it) and its
    /// faces from face number `next_face` on, and fills [`Fans::moved`]. An error says why the
    /// split does not fit the mesh (the caller names the split).
    pub fn split(&mut self, [vs, vl, vr]: [u32; 3], hole: Hole, vt: u32, next_face: u32) -> Result<(), String> {
        let valid = |v: u32| v == NO_VERTEX || v < vt;
        if vs >= vt
            || !valid(vl)
            || !valid(vr)
            || (vl == NO_VERTEX && vr == NO_VERTEX)
            || vl == vs
            || vr == vs
            || (vl == vr)
        {
            return Err(format!("vertex indices vs {vs} vl {vl} vr {vr} are invalid with {vt} vertices"));
        }
        if hole != Hole::None && (vl == NO_VERTEX || vr == NO_VERTEX) {
            return Err(format!("a split that opens a hole needs both vl and vr (vl {vl} vr {vr})"));
        }
        let limit = self.vertex_faces[vs as usize].len();
        self.moved.clear();
        // Faces from (vs, vr, ·) counter-clockwise to (vs, ·, vl) move to vt; with vr absent the
        // chain runs clockwise from (vs, ·, vl) to the boundary.
        // On a boundary edge the chain may be empty (vt was an ear with a single face).
        if vr != NO_VERTEX {
            let start = self.find_face(vs, |t| t[1] == vr);
            let mut f = match start {
                Some(f) => f,
                None if vl == NO_VERTEX => NO_VERTEX,
                None => return Err("no face with edge vs→vr".into()),
            };
            while f != NO_VERTEX {
                self.moved.push(f);
                let z = rotate_to(self.triangles[f as usize], vs)[2];
                if vl != NO_VERTEX && z == vl {
                    break;
                }
                match self.find_face(vs, |t| t[1] == z) {
                    Some(next) if self.moved.len() < limit => f = next,
                    None if vl == NO_VERTEX => break,
                    _ => return Err("the fan of vs does not lead from vr to vl".into()),
                }
            }
        } else {
            let mut f = self.find_face(vs, |t| t[2] == vl).unwrap_or(NO_VERTEX);
            while f != NO_VERTEX {
                self.moved.push(f);
                let y = rotate_to(self.triangles[f as usize], vs)[1];
                match self.find_face(vs, |t| t[2] == y) {
                    Some(prev) if self.moved.len() < limit => f = prev,
                    None => break,
                    _ => return Err("the fan of vs does not end at a boundary".into()),
                }
            }
        }
        for &f in &self.moved {
            for corner in self.triangles[f as usize].iter_mut() {
                if *corner == vs {
                    *corner = vt;
                }
            }
            self.vertex_faces[vs as usize].retain(|&g| g != f);
            self.vertex_faces[vt as usize].push(f);
        }
        let mut next_face = next_face;
        for (present, t) in sides_added(vl, vr, hole).into_iter().zip([[vs, vt, vl], [vt, vs, vr]]) {
            if present {
                self.triangles[next_face as usize] = t;
                for v in t {
                    self.vertex_faces[v as usize].push(next_face);
                }
                next_face += 1;
            }
        }
        Ok(())
    }

    /// Undoes a split: removes the faces `first..end` it added and renames `vt` back to `vs`.
    pub fn unsplit(&mut self, vs: u32, vt: u32, first: u32, end: u32) {
        for f in first..end {
            for v in self.triangles[f as usize] {
                self.vertex_faces[v as usize].retain(|&g| g != f);
            }
        }
        let faces = std::mem::take(&mut self.vertex_faces[vt as usize]);
        for &f in &faces {
            for corner in self.triangles[f as usize].iter_mut() {
                if *corner == vt {
                    *corner = vs;
                }
            }
        }
        self.vertex_faces[vs as usize].extend(faces);
    }
}

/// The mesh at one level of a progressive mesh, moved up (splits) or down (collapses) one step at
/// a time: going to a nearby level costs only the splits in between.
#[derive(Debug, Clone)]
pub struct LodCursor<'p> {
    pm: &'p ProgressiveMesh,
    level: usize,
    positions: Vec<[f32; 3]>,
    fans: Fans,
    /// With attributes: each face's corners (indices into the values), and the values each split
    /// replaced, as (face, corner, value), to put back when it is undone.
    corners: Vec<[u32; 3]>,
    replaced: Vec<(u32, u8, u32)>,
    replaced_ends: Vec<usize>,
}

/// `t` rotated so that `v` comes first.
#[inline]
fn rotate_to(t: [u32; 3], v: u32) -> [u32; 3] {
    if t[0] == v {
        t
    } else if t[1] == v {
        [t[1], t[2], t[0]]
    } else {
        [t[2], t[0], t[1]]
    }
}

impl<'p> LodCursor<'p> {
    /// A cursor at the base level.
    pub fn new(pm: &'p ProgressiveMesh) -> Self {
        let total_vertices = pm.base.vertex_count() + pm.splits.len();
        let total_faces = *pm.face_counts.last().expect("non-empty") as usize;
        let mut positions = Vec::with_capacity(total_vertices);
        positions.extend_from_slice(&pm.base.positions);
        positions.resize(total_vertices, [0.0; 3]);
        let fans = Fans::new(&pm.base.triangles, total_vertices, total_faces);
        let mut corners = Vec::new();
        if let Some(a) = &pm.attributes {
            corners.extend_from_slice(&a.base);
            corners.resize(total_faces, [0; 3]);
        }
        LodCursor { pm, level: 0, positions, fans, corners, replaced: Vec::new(), replaced_ends: Vec::new() }
    }

    /// Current level.
    pub fn level(&self) -> usize {
        self.level
    }

    /// Faces at the current level.
    pub fn face_count(&self) -> usize {
        self.pm.face_counts[self.level] as usize
    }

    /// Vertices at the current level.
    pub fn vertex_count(&self) -> usize {
        self.pm.base.vertex_count() + self.level
    }

    /// A copy of the current mesh.
    pub fn mesh(&self) -> Mesh {
        let corners = match &self.pm.attributes {
            Some(a) => a.values.pick(self.corners[..self.face_count()].iter().flatten().map(|&k| k as usize)),
            None => CornerAttributes::default(),
        };
        Mesh {
            positions: self.positions[..self.vertex_count()].to_vec(),
            triangles: self.fans.triangles[..self.face_count()].to_vec(),
            corners,
        }
    }

    /// Moves to `level` (clamped) by applying or undoing splits.
    pub fn seek_level(&mut self, level: usize) -> Result<(), MeshError> {
        let level = level.min(self.pm.splits.len());
        while self.level < level {
            self.refine()?;
        }
        while self.level > level {
            self.coarsen();
        }
        Ok(())
    }

    /// Moves to the finest level with at most `faces` faces.
    pub fn seek_faces(&mut self, faces: usize) -> Result<(), MeshError> {
        self.seek_level(self.pm.level_for_faces(faces))
    }

    fn corrupt(&self, reason: String) -> MeshError {
        MeshError::Parse { path: "<progressive mesh>".into(), location: format!("split {}", self.level), reason }
    }

    /// Applies the next split.
    pub fn refine(&mut self) -> Result<(), MeshError> {
        let Some(s) = self.pm.splits.get(self.level) else { return Ok(()) };
        let vt = self.vertex_count() as u32;
        let first = self.face_count();
        self.fans.split([s.vs, s.vl, s.vr], s.hole, vt, first as u32).map_err(|reason| self.corrupt(reason))?;
        if let Some(a) = self.pm.attributes.as_ref().map(|a| &a.splits[self.level]) {
            for &f in &self.fans.moved {
                let k = self.fans.triangles[f as usize].iter().position(|&v| v == vt).expect("moved to vt");
                // The value the corner had before the collapse that this split undoes.
                if let Some(&(_, value)) = a.moved.iter().find(|m| m.0 == f) {
                    self.replaced.push((f, k as u8, self.corners[f as usize][k]));
                    self.corners[f as usize][k] = value;
                }
            }
            self.replaced_ends.push(self.replaced.len());
            for (added, corners) in a.new_faces[..s.added_faces()].iter().enumerate() {
                self.corners[first + added] = *corners;
            }
        }
        self.positions[s.vs as usize] = s.split_position;
        self.positions[vt as usize] = s.new_position;
        self.level += 1;
        Ok(())
    }

    /// Undoes the last split (an edge collapse).
    pub fn coarsen(&mut self) {
        if self.level == 0 {
            return;
        }
        self.level -= 1;
        let s = self.pm.splits[self.level];
        let vt = self.vertex_count() as u32;
        self.fans.unsplit(s.vs, vt, self.pm.face_counts[self.level], self.pm.face_counts[self.level + 1]);
        self.positions[s.vs as usize] = s.collapsed_position;
        if self.pm.attributes.is_some() {
            self.replaced_ends.pop();
            let start = self.replaced_ends.last().copied().unwrap_or(0);
            for (f, k, value) in self.replaced.drain(start..).rev() {
                self.corners[f as usize][k as usize] = value;
            }
        }
    }
}
