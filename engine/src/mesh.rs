//! The indexed triangle mesh every algorithm reads and writes.
//!
//! Positions are stored as `f32` exactly as read from a file (so a round trip is bit-exact); every
//! geometric computation widens them to `f64` first (`Mesh::point`).

use glam::DVec3;
use serde::Serialize;

use crate::error::MeshError;
pub use crate::library::{Image, ImageSource, MaterialLibrary, OtherPrimitive, Rig, RigAccessor};

/// Index of a vertex in [`Mesh::positions`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default, Serialize)]
pub struct VertexId(pub u32);

/// Index of a triangle in [`Mesh::triangles`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default, Serialize)]
pub struct FaceId(pub u32);

impl VertexId {
    /// The id as a `usize` for indexing per-vertex arrays.
    #[inline]
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

impl FaceId {
    /// The id as a `usize` for indexing per-face arrays.
    #[inline]
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// Per-corner attributes read from a file (texture coordinates with their seams, split normals,
/// colours).
///
/// Each array, when present, holds one entry per triangle corner: `3 * triangles.len()` entries,
/// in triangle order, so a vertex on a seam has different values in the faces on either side.
/// Reading, writing, cleaning, converting, simplifying, the progressive mesh and refinement keep
/// them (a seam vertex collapses only along its seam; subdivision interpolates them per face).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CornerAttributes {
    /// Texture coordinates per corner, with v pointing up from the image's bottom-left corner (as
    /// OBJ, PLY and OpenGL have them) unless `uv_origin_top` says otherwise.
    pub uvs: Option<Vec<[f32; 2]>>,
    /// A second set of texture coordinates per corner (glTF TEXCOORD_1: a light map, an
    /// occlusion map), with the same origin as `uvs`.
    pub uvs1: Option<Vec<[f32; 2]>>,
    /// True when `uvs` have v pointing down from the image's top-left corner, as glTF has them (so
    /// that a glTF read and written again keeps its values bit for bit); writers of the other
    /// convention write 1 − v.
    pub uv_origin_top: bool,
    /// Normals per corner.
    pub normals: Option<Vec<[f32; 3]>>,
    /// Tangents per corner (glTF TANGENT): a unit vector along the texture's u direction and, as
    /// the fourth component, ±1 for the handedness of the bitangent.
    pub tangents: Option<Vec<[f32; 4]>>,
    /// Colours per corner, RGBA in [0, 1].
    pub colors: Option<Vec<[f32; 4]>>,
    /// Skinning per corner (glTF JOINTS_0): the four joints, as indices into the rig's skin's
    /// `joints`, that move the corner's vertex. Present exactly when `weights` is.
    pub joints: Option<Vec<[u16; 4]>>,
    /// Skinning per corner (glTF WEIGHTS_0): how much each of `joints` moves the vertex.
    pub weights: Option<Vec<[f32; 4]>>,
    /// Material per corner (the same at a face's three corners): an index into `library`'s
    /// materials, or [`NO_MATERIAL`]. A vertex where faces of two materials meet is a seam.
    pub materials: Option<Vec<u32>>,
    /// The materials, textures and images that `materials` refers to, as read (shared, not
    /// copied, by every mesh made from this one).
    pub library: Option<std::sync::Arc<MaterialLibrary>>,
}

/// No vertex, face, edge, corner or value: the one sentinel of the engine's `u32` index arrays
/// (an absent `vl` or `vr` of a vertex split, a face corner outside the edge table, an empty slot).
pub const NONE: u32 = u32::MAX;

/// The material value of a face that has none (glTF's default material): [`NONE`] as a material
/// number.
pub const NO_MATERIAL: u32 = NONE;

/// Scales a vertex's skin weights to sum to 1, as glTF requires (negative ones taken as 0): the
/// sum taken in order in single precision, as the Khronos validator takes it, is then 1 within its
/// tolerance (2e-7 per weight that is not 0). Whether they changed; weights that already sum to 1
/// or have no positive one are left as they are.
pub fn normalize_weights(w: &mut [f32; 4]) -> bool {
    let sum = |w: &[f32; 4]| w.iter().fold(0f32, |s, &x| s + x);
    let close = |w: &[f32; 4]| {
        let tolerance = 2e-7 * w.iter().filter(|&&x| x != 0.0).count() as f64;
        (sum(w) as f64 - 1.0).abs() <= tolerance && w.iter().all(|&x| x >= 0.0)
    };
    let total: f64 = w.iter().map(|&x| x.max(0.0) as f64).sum();
    if close(w) || !(total > 0.0 && total.is_finite()) {
        return false;
    }
    *w = w.map(|x| (x.max(0.0) as f64 / total) as f32);
    if !close(w) {
        // The rounding left on the largest weight.
        let k = (0..4).max_by(|&a, &b| w[a].total_cmp(&w[b])).unwrap_or(0);
        w[k] += 1.0 - sum(w);
    }
    true
}

/// Whether corners `a` and `b` carry the same value of an attribute (bit for bit), or it is absent.
fn same_bits<const N: usize>(values: &Option<Vec<[f32; N]>>, a: usize, b: usize) -> bool {
    values.as_ref().is_none_or(|v| v[a].map(f32::to_bits) == v[b].map(f32::to_bits))
}

impl CornerAttributes {
    /// What the input had that is not carried ([`MaterialLibrary::not_carried`]): a warning, or
    /// `None` when nothing is left out.
    pub fn not_carried_warning(&self) -> Option<String> {
        let list = &self.library.as_ref()?.not_carried;
        (!list.is_empty()).then(|| format!("the input's {} are not carried: the result has none", list.join(", ")))
    }

    /// What every command that writes a result says of its input: [`Self::not_carried_warning`],
    /// [`Self::passed_through_note`] and what the reader mended ([`MaterialLibrary::mended`]).
    pub fn input_warnings(&self) -> impl Iterator<Item = String> {
        let mended = self.library.as_ref().map(|l| l.mended.clone()).unwrap_or_default();
        self.not_carried_warning().into_iter().chain(self.passed_through_note()).chain(mended)
    }

    /// What the input had that is carried as it was ([`MaterialLibrary::other_primitives`]): a
    /// note, or `None` when there is none.
    pub fn passed_through_note(&self) -> Option<String> {
        let n = self.library.as_ref()?.other_primitives.len();
        (n > 0).then(|| {
            format!("the input's {n} point and line primitive(s) are carried as they were into a glTF result (only triangles are simplified or refined)")
        })
    }
}

/// Vertices split by attributes: see [`CornerAttributes::wedges`].
#[derive(Debug, Clone, PartialEq)]
pub struct Wedges {
    /// Per output vertex: a corner that has it, or (when `identity`) the vertex itself.
    pub source: Vec<usize>,
    /// Per corner (3 per triangle): its output vertex.
    pub corner_vertex: Vec<u32>,
    /// True when there are no attributes and the output vertices are the mesh's own.
    pub identity: bool,
}

impl Wedges {
    /// The mesh vertex of output vertex `i`.
    pub fn vertex(&self, triangles: &[[u32; 3]], i: usize) -> usize {
        let k = self.source[i];
        if self.identity { k } else { triangles[k / 3][k % 3] as usize }
    }
}

impl CornerAttributes {
    /// Names of the attributes present, as `info` lists them: "normal", "uv", "color".
    pub fn names(&self) -> Vec<&'static str> {
        let mut names = Vec::new();
        if self.normals.is_some() {
            names.push("normal");
        }
        if self.uvs.is_some() {
            names.push("uv");
        }
        if self.uvs1.is_some() {
            names.push("uv1");
        }
        if self.tangents.is_some() {
            names.push("tangent");
        }
        if self.colors.is_some() {
            names.push("color");
        }
        if self.joints.is_some() {
            names.push("joints");
        }
        if self.weights.is_some() {
            names.push("weights");
        }
        if self.materials.is_some() {
            names.push("material");
        }
        names
    }

    /// Number of values each present array holds (the length of the first one; 0 without any).
    pub fn value_count(&self) -> usize {
        [
            self.uvs.as_ref().map(Vec::len),
            self.uvs1.as_ref().map(Vec::len),
            self.normals.as_ref().map(Vec::len),
            self.tangents.as_ref().map(Vec::len),
            self.colors.as_ref().map(Vec::len),
            self.joints.as_ref().map(Vec::len),
            self.weights.as_ref().map(Vec::len),
            self.materials.as_ref().map(Vec::len),
        ]
        .into_iter()
        .flatten()
        .next()
        .unwrap_or(0)
    }

    /// Whether there is no attribute.
    pub fn is_empty(&self) -> bool {
        !self.has_values() && self.materials.is_none()
    }

    /// Whether there is a value besides the material (what splits a vertex in a format without
    /// materials).
    fn has_values(&self) -> bool {
        self.uvs.is_some()
            || self.uvs1.is_some()
            || self.normals.is_some()
            || self.tangents.is_some()
            || self.colors.is_some()
            || self.joints.is_some()
    }

    /// The attributes of the corners `kept` (corner indices), in that order.
    pub fn pick(&self, kept: impl Iterator<Item = usize> + Clone) -> CornerAttributes {
        fn pick<T: Copy>(values: &Option<Vec<T>>, kept: impl Iterator<Item = usize>) -> Option<Vec<T>> {
            values.as_ref().map(|v| kept.map(|c| v[c]).collect())
        }
        CornerAttributes {
            uvs: pick(&self.uvs, kept.clone()),
            uvs1: pick(&self.uvs1, kept.clone()),
            normals: pick(&self.normals, kept.clone()),
            tangents: pick(&self.tangents, kept.clone()),
            colors: pick(&self.colors, kept.clone()),
            joints: pick(&self.joints, kept.clone()),
            weights: pick(&self.weights, kept.clone()),
            materials: pick(&self.materials, kept),
            library: self.library.clone(),
            uv_origin_top: self.uv_origin_top,
        }
    }

    /// A number per corner of `triangles` (over `vertex_count` vertices): two corners of the same
    /// vertex have the same number exactly when [`CornerAttributes::same`] holds for them (the
    /// number is the first such corner). Comparing two numbers is what a simplifier asks millions
    /// of times.
    pub fn value_ids(&self, triangles: &[[u32; 3]], vertex_count: usize) -> Vec<u32> {
        self.row_ids(triangles, vertex_count, true)
    }

    /// [`CornerAttributes::value_ids`], the materials left out unless `with_materials`.
    fn row_ids(&self, triangles: &[[u32; 3]], vertex_count: usize, with_materials: bool) -> Vec<u32> {
        let materials = self.materials.as_ref().filter(|_| with_materials);
        let same = |a: usize, b: usize| self.same_values(a, b) && materials.is_none_or(|m| m[a] == m[b]);
        // Per vertex, the corners with distinct values met so far (a chain through `next`): a
        // corner takes the number of the first one with its values, else starts a new one. (The
        // values are compared where they are: a copy of them as rows of words cost more than the
        // comparisons, about one per corner.)
        let corner_count = 3 * triangles.len();
        let mut first = vec![u32::MAX; vertex_count];
        let mut next = vec![u32::MAX; corner_count];
        let mut ids = vec![0u32; corner_count];
        for (k, &v) in triangles.iter().flatten().enumerate() {
            let mut r = first[v as usize];
            let mut last = u32::MAX;
            while r != u32::MAX && !same(r as usize, k) {
                last = r;
                r = next[r as usize];
            }
            if r == u32::MAX {
                r = k as u32;
                if last == u32::MAX {
                    first[v as usize] = r;
                } else {
                    next[last as usize] = r;
                }
            }
            ids[k] = r;
        }
        ids
    }

    /// Whether corners `a` and `b` carry the same attributes, bit for bit.
    pub fn same(&self, a: usize, b: usize) -> bool {
        self.same_values(a, b) && self.materials.as_ref().is_none_or(|m| m[a] == m[b])
    }

    /// [`CornerAttributes::same`] for every attribute but the normal (a double-sided sheet's back
    /// may carry its front's values with the normals turned round).
    pub fn same_but_normals(&self, a: usize, b: usize) -> bool {
        self.same_values_but_normals(a, b) && self.materials.as_ref().is_none_or(|m| m[a] == m[b])
    }

    /// [`CornerAttributes::same`], the materials left out.
    fn same_values(&self, a: usize, b: usize) -> bool {
        same_bits(&self.normals, a, b) && self.same_values_but_normals(a, b)
    }

    /// [`CornerAttributes::same_values`], the normals left out.
    fn same_values_but_normals(&self, a: usize, b: usize) -> bool {
        same_bits(&self.uvs, a, b)
            && same_bits(&self.uvs1, a, b)
            && same_bits(&self.tangents, a, b)
            && same_bits(&self.colors, a, b)
            && same_bits(&self.weights, a, b)
            && self.joints.as_ref().is_none_or(|j| j[a] == j[b])
    }

    /// Splits the mesh's vertices where their corners differ, for formats with one value per
    /// vertex (PLY, glTF, GPU buffers): one output vertex per distinct (vertex, attributes) pair.
    /// Returns, per output vertex, a corner that has it (so its vertex and values), and per corner
    /// its output vertex. Without attributes the vertices stay as they are (every vertex, used or
    /// not; `source` then holds vertex indices, marked by [`Wedges::identity`]).
    pub fn wedges(&self, triangles: &[[u32; 3]], vertex_count: usize) -> Wedges {
        self.split_vertices(triangles, vertex_count, true)
    }

    /// [`CornerAttributes::wedges`] for a format without materials (PLY, the contract's `Mesh`):
    /// vertices split by their values only.
    pub fn value_wedges(&self, triangles: &[[u32; 3]], vertex_count: usize) -> Wedges {
        self.split_vertices(triangles, vertex_count, false)
    }

    fn split_vertices(&self, triangles: &[[u32; 3]], vertex_count: usize, by_material: bool) -> Wedges {
        let materials = self.materials.as_ref().filter(|_| by_material);
        if !self.has_values() && materials.is_none() {
            return Wedges {
                source: (0..vertex_count).collect(),
                corner_vertex: triangles.iter().flatten().copied().collect(),
                identity: true,
            };
        }
        // One output vertex per corner that is the first of its vertex with its values, in the
        // mesh's vertex order (a vertex's copies in the order its corners first use them), so that a
        // reader joining the copies again (`Mesh::join_cut_seams`) numbers the vertices as they
        // were: a mesh written and read back simplifies as it did before.
        let ids = self.row_ids(triangles, vertex_count, by_material);
        let vertex_of = |k: usize| triangles[k / 3][k % 3];
        let mut source: Vec<usize> = (0..ids.len()).filter(|&k| ids[k] as usize == k).collect();
        source.sort_by_key(|&k| (vertex_of(k), k));
        let mut rank = vec![0u32; ids.len()];
        for (r, &k) in source.iter().enumerate() {
            rank[k] = r as u32;
        }
        let corner_vertex = ids.iter().map(|&id| rank[id as usize]).collect();
        Wedges { source, corner_vertex, identity: false }
    }

    /// The texture coordinates with v pointing down (`top` true, glTF) or up (OBJ, PLY), flipped
    /// (v → 1 − v) when stored the other way.
    pub fn uvs_with_origin(&self, top: bool) -> Option<std::borrow::Cow<'_, [[f32; 2]]>> {
        self.uvs.as_deref().map(|uvs| self.with_origin(uvs, top))
    }

    /// [`CornerAttributes::uvs_with_origin`] for the second set.
    pub fn uvs1_with_origin(&self, top: bool) -> Option<std::borrow::Cow<'_, [[f32; 2]]>> {
        self.uvs1.as_deref().map(|uvs| self.with_origin(uvs, top))
    }

    fn with_origin<'a>(&self, uvs: &'a [[f32; 2]], top: bool) -> std::borrow::Cow<'a, [[f32; 2]]> {
        if top == self.uv_origin_top {
            std::borrow::Cow::Borrowed(uvs)
        } else {
            std::borrow::Cow::Owned(uvs.iter().map(|&[u, v]| [u, 1.0 - v]).collect())
        }
    }

    /// Checks the joints and weights: both or neither, one per value, and every joint one of the
    /// rig's skin (a `.pm` file's value table is checked with it too).
    pub(crate) fn check_skin(&self, count: usize) -> Result<(), MeshError> {
        match &self.joints {
            Some(joints) if joints.len() != count => {
                return Err(MeshError::InvalidParameter {
                    name: "joints",
                    reason: format!("{} per-corner values for {count} corners", joints.len()),
                });
            }
            Some(_) if self.weights.is_none() => {
                return Err(MeshError::InvalidParameter { name: "weights", reason: "joints without weights".into() });
            }
            None if self.weights.is_some() => {
                return Err(MeshError::InvalidParameter { name: "joints", reason: "weights without joints".into() });
            }
            _ => {}
        }
        if let Some(joints) = &self.joints {
            let rig = self.library.as_ref().and_then(|l| l.rig.as_ref());
            let known = rig.map_or(0, Rig::joint_count);
            if let Some(corner) = joints.iter().position(|j| j.iter().any(|&x| x as usize >= known)) {
                let reason = match rig {
                    None => "joints without a skin to refer to".to_string(),
                    Some(_) => format!(
                        "corner {corner} (face {}) names joint {}; the skin has {known}",
                        corner / 3,
                        joints[corner].iter().max().copied().unwrap_or(0)
                    ),
                };
                return Err(MeshError::InvalidParameter { name: "joints", reason });
            }
        }
        Ok(())
    }

    /// Checks one entry per corner and finite values; errors name the attribute and the corner.
    fn check(&self, corner_count: usize) -> Result<(), MeshError> {
        fn check<const N: usize>(
            values: &Option<Vec<[f32; N]>>,
            name: &'static str,
            corner_count: usize,
        ) -> Result<(), MeshError> {
            let Some(values) = values else { return Ok(()) };
            if values.len() != corner_count {
                return Err(MeshError::InvalidParameter {
                    name,
                    reason: format!("{} per-corner values for {corner_count} corners", values.len()),
                });
            }
            if let Some(corner) = first_non_finite(values) {
                return Err(MeshError::InvalidParameter {
                    name,
                    reason: format!("corner {corner} (face {}) has a non-finite value", corner / 3),
                });
            }
            Ok(())
        }
        check(&self.uvs, "uv", corner_count)?;
        check(&self.uvs1, "uv1", corner_count)?;
        check(&self.normals, "normal", corner_count)?;
        check(&self.tangents, "tangent", corner_count)?;
        check(&self.colors, "color", corner_count)?;
        check(&self.weights, "weights", corner_count)?;
        self.check_skin(corner_count)?;
        if let Some(materials) = &self.materials {
            let reason = if materials.len() != corner_count {
                Some(format!("{} per-corner values for {corner_count} corners", materials.len()))
            } else if let Some(face) = materials.chunks(3).position(|m| m[0] != m[1] || m[1] != m[2]) {
                Some(format!("face {face} has corners of different materials"))
            } else {
                let known = self.library.as_ref().map_or(0, |l| l.materials.len());
                materials.iter().position(|&m| m != NO_MATERIAL && m as usize >= known).map(|corner| {
                    format!("face {} names material {}; there are {known}", corner / 3, materials[corner])
                })
            };
            if let Some(reason) = reason {
                return Err(MeshError::InvalidParameter { name: "material", reason });
            }
        }
        if let Some(library) = &self.library {
            for (i, other) in library.other_primitives.iter().enumerate() {
                other.check(library.materials.len()).map_err(|reason| MeshError::InvalidParameter {
                    name: "other_primitives",
                    reason: format!("point or line primitive {i}: {reason}"),
                })?;
            }
        }
        Ok(())
    }
}

/// An indexed triangle mesh.
///
/// Invariants upheld by [`Mesh::new`]: every coordinate is finite and every index is in range.
/// Degenerate, duplicate or non-manifold faces are allowed (they are reported by
/// [`crate::validate::validate`] and removed by [`crate::validate::clean`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions, as read.
    pub positions: Vec<[f32; 3]>,
    /// Triangles as counter-clockwise vertex index triples.
    pub triangles: Vec<[u32; 3]>,
    /// Optional per-corner attributes.
    pub corners: CornerAttributes,
}

/// An axis-aligned bounding box in f64.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Bounds {
    /// Smallest corner.
    pub min: [f64; 3],
    /// Largest corner.
    pub max: [f64; 3],
}

impl Bounds {
    /// Length of the box diagonal.
    pub fn diagonal(&self) -> f64 {
        (DVec3::from(self.max) - DVec3::from(self.min)).length()
    }

    /// Length of the largest side.
    pub fn largest_side(&self) -> f64 {
        (DVec3::from(self.max) - DVec3::from(self.min)).max_element()
    }

    /// Centre of the box.
    pub fn center(&self) -> DVec3 {
        (DVec3::from(self.max) + DVec3::from(self.min)) * 0.5
    }
}

impl Mesh {
    /// Builds a mesh, checking that coordinates are finite and indices are in range.
    pub fn new(positions: Vec<[f32; 3]>, triangles: Vec<[u32; 3]>) -> Result<Mesh, MeshError> {
        let mesh = Mesh { positions, triangles, corners: CornerAttributes::default() };
        mesh.check()?;
        Ok(mesh)
    }

    /// Checks the invariants documented on [`Mesh`].
    pub fn check(&self) -> Result<(), MeshError> {
        if let Some(vertex) = first_non_finite(&self.positions) {
            let value = self.positions[vertex].into_iter().find(|c| !c.is_finite()).unwrap_or(f32::NAN);
            return Err(MeshError::NonFiniteCoordinate { vertex, value: value.to_string() });
        }
        let vertex_count = self.positions.len();
        // The largest index first, in one pass without a branch per index; the face only on failure.
        let largest = self.triangles.iter().flatten().fold(0u32, |m, &i| m.max(i));
        if largest as usize >= vertex_count {
            for (face, t) in self.triangles.iter().enumerate() {
                if let Some(&index) = t.iter().find(|&&i| i as usize >= vertex_count) {
                    return Err(MeshError::IndexOutOfRange { face, index: index as i64, vertex_count });
                }
            }
        }
        self.corners.check(3 * self.triangles.len())
    }

    /// For each vertex, the first vertex at its position (bit-identical, −0 and +0 alike): itself
    /// where it is the first or the only one there.
    pub fn first_at_each_position(&self) -> Vec<u32> {
        let mut first: std::collections::HashMap<[u32; 3], u32> =
            std::collections::HashMap::with_capacity(self.positions.len());
        let key = |p: &[f32; 3]| p.map(|c| (c + 0.0).to_bits());
        (0..self.positions.len() as u32).map(|v| *first.entry(key(&self.positions[v as usize])).or_insert(v)).collect()
    }

    /// Number of vertices (including unreferenced ones).
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Number of triangles.
    pub fn face_count(&self) -> usize {
        self.triangles.len()
    }

    /// Position of a vertex, widened to f64.
    #[inline]
    pub fn point(&self, v: u32) -> DVec3 {
        let p = self.positions[v as usize];
        DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
    }

    /// The three corners of a triangle, widened to f64.
    #[inline]
    pub fn triangle_points(&self, f: usize) -> [DVec3; 3] {
        let [a, b, c] = self.triangles[f];
        [self.point(a), self.point(b), self.point(c)]
    }

    /// Unnormalised face normal (twice the area vector).
    #[inline]
    pub fn face_area_vector(&self, f: usize) -> DVec3 {
        let [a, b, c] = self.triangle_points(f);
        (b - a).cross(c - a)
    }

    /// Area of a triangle.
    pub fn face_area(&self, f: usize) -> f64 {
        0.5 * self.face_area_vector(f).length()
    }

    /// Bounding box of the vertices that some face references; `None` if there are no faces.
    ///
    /// Unreferenced vertices do not count: they are not part of the surface.
    pub fn surface_bounds(&self) -> Option<Bounds> {
        let mut min = DVec3::splat(f64::INFINITY);
        let mut max = DVec3::splat(f64::NEG_INFINITY);
        for t in &self.triangles {
            for &v in t {
                let p = self.point(v);
                min = min.min(p);
                max = max.max(p);
            }
        }
        (!self.triangles.is_empty()).then(|| Bounds { min: min.into(), max: max.into() })
    }

    /// Bounding box of all vertices; `None` if there are none.
    pub fn bounds(&self) -> Option<Bounds> {
        let mut min = DVec3::splat(f64::INFINITY);
        let mut max = DVec3::splat(f64::NEG_INFINITY);
        for v in 0..self.positions.len() {
            let p = self.point(v as u32);
            min = min.min(p);
            max = max.max(p);
        }
        (!self.positions.is_empty()).then(|| Bounds { min: min.into(), max: max.into() })
    }

    /// Total surface area.
    pub fn area(&self) -> f64 {
        (0..self.triangles.len()).map(|f| self.face_area(f)).sum()
    }
}

/// Distances in meshlod are reported in two units, both relative to a reference mesh's bounding box.
///
/// * **paper units**: the mesh centred and scaled so that the largest side of its bounding box spans
///   [−1, 1], i.e. `distance × 2 / largest_side`. This is the unit of the QFVP paper's tables.
/// * **% of diagonal**: `distance / diagonal × 100`, the unit MeshLab's Metro prints.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DistanceUnits {
    largest_side: f64,
    diagonal: f64,
}

impl DistanceUnits {
    /// Units relative to `bounds`.
    pub fn new(bounds: &Bounds) -> Self {
        DistanceUnits { largest_side: bounds.largest_side(), diagonal: bounds.diagonal() }
    }

    /// Converts an absolute distance to paper units.
    pub fn to_paper(&self, distance: f64) -> f64 {
        if self.largest_side > 0.0 { distance * 2.0 / self.largest_side } else { 0.0 }
    }

    /// Converts an absolute distance to percent of the bounding-box diagonal.
    pub fn to_diagonal_percent(&self, distance: f64) -> f64 {
        if self.diagonal > 0.0 { distance / self.diagonal * 100.0 } else { 0.0 }
    }

    /// Converts a distance in paper units back to an absolute distance.
    pub fn from_paper(&self, paper: f64) -> f64 {
        paper * self.largest_side / 2.0
    }
}

/// The first of `values` with a component that is not finite: one pass without a branch per
/// component (validation reads every value of every mesh), the position only on failure.
fn first_non_finite<const N: usize>(values: &[[f32; N]]) -> Option<usize> {
    let all_finite = values.iter().flatten().fold(true, |ok, c| ok & c.is_finite());
    if all_finite { None } else { values.iter().position(|v| v.iter().any(|c| !c.is_finite())) }
}
