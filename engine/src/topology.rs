//! Adjacency built once from an indexed mesh: vertex→faces, edges, edge→faces.
//!
//! Compressed (CSR) arrays rather than a half-edge structure: they tolerate any input, including
//! non-manifold edges and bowtie vertices, which is what validation must look at. The simplifier
//! and the refiner build their own mutable structures from these.

use crate::mesh::{FaceId, Mesh};

/// A compressed sparse row list: `items[offsets[i]..offsets[i + 1]]` belong to key `i`.
#[derive(Debug, Clone, Default)]
pub struct Csr<T> {
    offsets: Vec<u32>,
    items: Vec<T>,
}

impl<T: Copy> Csr<T> {
    /// Builds the list from `(key, item)` pairs; items keep their input order within a key.
    pub fn from_pairs(key_count: usize, pairs: impl Iterator<Item = (usize, T)> + Clone) -> Self {
        let mut offsets = vec![0u32; key_count + 1];
        for (k, _) in pairs.clone() {
            offsets[k + 1] += 1;
        }
        for i in 0..key_count {
            offsets[i + 1] += offsets[i];
        }
        let mut cursor = offsets.clone();
        let mut items: Vec<Option<T>> = vec![None; offsets[key_count] as usize];
        for (k, item) in pairs {
            items[cursor[k] as usize] = Some(item);
            cursor[k] += 1;
        }
        Csr { offsets, items: items.into_iter().map(|i| i.expect("every slot is filled")).collect() }
    }

    /// Items of key `i`.
    #[inline]
    pub fn get(&self, i: usize) -> &[T] {
        &self.items[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }

    /// Number of keys.
    pub fn len(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// Whether there are no keys.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Marks a face corner whose edge is not part of the edge table (the face repeats a vertex):
/// [`crate::mesh::NONE`].
pub use crate::mesh::NONE as NO_EDGE;

/// Edge and incidence tables of a mesh.
#[derive(Debug, Clone)]
pub struct Topology {
    /// Faces around each vertex.
    pub vertex_faces: Csr<FaceId>,
    /// Undirected edges as `[low, high]` vertex pairs, sorted.
    pub edges: Vec<[u32; 2]>,
    /// Faces on each edge.
    pub edge_faces: Csr<FaceId>,
    /// For each face, the edge id of corner `i`'s edge `(t[i], t[(i + 1) % 3])`, or [`NO_EDGE`].
    pub face_edges: Vec<[u32; 3]>,
}

impl Topology {
    /// Builds the tables. Faces that repeat a vertex take part in `vertex_faces` but not in edges.
    pub fn new(mesh: &Mesh) -> Topology {
        let tris = &mesh.triangles;
        let vertex_faces = Csr::from_pairs(
            mesh.vertex_count(),
            tris.iter().enumerate().flat_map(|(f, t)| t.iter().map(move |&v| (v as usize, FaceId(f as u32)))),
        );
        let mut half: Vec<(u32, u32, u32, u8)> = Vec::with_capacity(tris.len() * 3);
        for (f, t) in tris.iter().enumerate() {
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                continue;
            }
            for i in 0..3 {
                let (a, b) = (t[i], t[(i + 1) % 3]);
                half.push((a.min(b), a.max(b), f as u32, i as u8));
            }
        }
        half.sort_unstable();
        let mut edges: Vec<[u32; 2]> = Vec::with_capacity(half.len() / 2 + 1);
        let mut face_edges = vec![[NO_EDGE; 3]; tris.len()];
        let mut pairs: Vec<(usize, FaceId)> = Vec::with_capacity(half.len());
        for &(a, b, f, corner) in &half {
            if edges.last() != Some(&[a, b]) {
                edges.push([a, b]);
            }
            let e = edges.len() - 1;
            face_edges[f as usize][corner as usize] = e as u32;
            pairs.push((e, FaceId(f)));
        }
        let edge_faces = Csr::from_pairs(edges.len(), pairs.into_iter());
        Topology { vertex_faces, edges, edge_faces, face_edges }
    }
}

/// Disjoint sets with path halving and union by size.
#[derive(Debug, Clone)]
pub struct UnionFind {
    parent: Vec<u32>,
    size: Vec<u32>,
}

impl UnionFind {
    /// `n` singleton sets.
    pub fn new(n: usize) -> Self {
        UnionFind { parent: (0..n as u32).collect(), size: vec![1; n] }
    }

    /// Representative of `x`'s set.
    pub fn find(&mut self, mut x: u32) -> u32 {
        while self.parent[x as usize] != x {
            let grand = self.parent[self.parent[x as usize] as usize];
            self.parent[x as usize] = grand;
            x = grand;
        }
        x
    }

    /// Merges the sets of `a` and `b`; returns whether they were apart.
    pub fn union(&mut self, a: u32, b: u32) -> bool {
        let (mut ra, mut rb) = (self.find(a), self.find(b));
        if ra == rb {
            return false;
        }
        if self.size[ra as usize] < self.size[rb as usize] {
            std::mem::swap(&mut ra, &mut rb);
        }
        self.parent[rb as usize] = ra;
        self.size[ra as usize] += self.size[rb as usize];
        true
    }
}

impl Mesh {
    /// Joins what a vertex-per-set-of-values layout (glTF, PLY, many OBJ exporters) cuts open: a
    /// seam arrives as two borders at the same positions, one running each way. Two border edges
    /// are zipped where they are the only ones between a pair of bit-identical positions (−0 and +0
    /// alike) and run opposite ways, as the two sides of a cut do; a border edge of zero length
    /// (a UV sphere's pole, one vertex per face) joins its two ends. Each joined edge then has two
    /// faces that agree on its direction, so the surface is one piece with seams (an edge whose
    /// faces differ in their corners' values) rather than two borders that the simplifier would
    /// move apart. Vertices that merely coincide — two sheets of a double-sided garment, parts
    /// that touch — stay apart: joined, they would make edges of three or more faces, or faces
    /// that disagree on direction. A vertex that no face uses joins one at its position.
    /// The first vertex of each joined set keeps its place (the others' positions are dropped,
    /// the order kept); per-corner attributes are untouched.
    /// Returns the number of vertices joined away.
    pub fn join_cut_seams(&mut self) -> usize {
        use crate::mesh::NONE;
        let n = self.positions.len();
        // Each vertex's place: the first vertex at its position.
        let place = self.first_at_each_position();
        let at = |v: u32| place[v as usize];
        // Only a vertex that shares its position with another can join.
        let mut sharing = vec![0u32; n];
        place.iter().for_each(|&p| sharing[p as usize] += 1);
        if sharing.iter().all(|&c| c <= 1) {
            return 0;
        }
        let shared = |v: u32| sharing[at(v) as usize] > 1;
        let pair = |a: u32, b: u32| (u64::from(a.min(b)) << 32) | u64::from(a.max(b));
        // The directed edges with a shared end (all of a pair's, or none), sorted by their vertex
        // pair: a pair met once is a border edge. Those sorted by their pair of places: the border
        // edges between the same two positions.
        let mut edges: Vec<(u64, [u32; 2])> = self
            .triangles
            .iter()
            .flat_map(|t| [[t[0], t[1]], [t[1], t[2]], [t[2], t[0]]])
            .filter(|&[a, b]| a != b && (shared(a) || shared(b)))
            .map(|[a, b]| (pair(a, b), [a, b]))
            .collect();
        edges.sort_unstable_by_key(|e| e.0);
        let mut borders: Vec<(u64, [u32; 2])> = edges
            .chunk_by(|x, y| x.0 == y.0)
            .filter_map(|run| match *run {
                [(_, [a, b])] => Some((pair(at(a), at(b)), [a, b])),
                _ => None,
            })
            .collect();
        drop(edges);
        borders.sort_unstable_by_key(|e| e.0);
        let mut sets = UnionFind::new(n);
        for run in borders.chunk_by(|x, y| x.0 == y.0) {
            match *run {
                // Zero length (every edge of the run is): a pole's copies.
                [(_, [a, b]), ..] if at(a) == at(b) => run.iter().for_each(|&(_, [a, b])| {
                    sets.union(a, b);
                }),
                [(_, [a, b]), (_, [c, d])] if at(a) == at(d) && at(b) == at(c) => {
                    sets.union(a, d);
                    sets.union(b, c);
                }
                _ => {}
            }
        }
        // A vertex that no face uses (a glTF primitive's share of a vertex buffer that several
        // use) joins the first used vertex at its position, else the first there.
        let mut used = vec![false; n];
        self.triangles.iter().flatten().for_each(|&v| used[v as usize] = true);
        let mut first_used = vec![NONE; n];
        for v in (0..n as u32).filter(|&v| used[v as usize]) {
            if first_used[at(v) as usize] == NONE {
                first_used[at(v) as usize] = v;
            }
        }
        for v in (0..n as u32).filter(|&v| !used[v as usize]) {
            let there = first_used[at(v) as usize];
            sets.union(v, if there == NONE { at(v) } else { there });
        }
        let mut first = vec![NONE; n];
        let mut remap = vec![0u32; n];
        let mut positions = Vec::with_capacity(n);
        for v in 0..n as u32 {
            let root = sets.find(v) as usize;
            if first[root] == NONE {
                first[root] = positions.len() as u32;
                positions.push(self.positions[v as usize]);
            }
            remap[v as usize] = first[root];
        }
        let joined = n - positions.len();
        self.positions = positions;
        self.triangles.iter_mut().for_each(|t| *t = t.map(|v| remap[v as usize]));
        joined
    }
}

#[cfg(test)]
mod tests {
    use crate::mesh::Mesh;
    use crate::validate::validate;

    /// A strip of `n` quads along x, each split in two; `cut` gives the faces right of x = 1 their
    /// own copies of the vertices on that line (a seam cut open, as a vertex-per-value file has it).
    fn strip(n: u32, cut: bool) -> Mesh {
        let mut positions = Vec::new();
        for x in 0..=n {
            positions.extend([[x as f32, 0.0, 0.0], [x as f32, 1.0, 0.0]]);
        }
        let copies = positions.len() as u32;
        if cut {
            positions.extend([[1.0, 0.0, 0.0], [1.0, 1.0, 0.0]]);
        }
        let at = |x: u32, y: u32, right: bool| if cut && x == 1 && right { copies + y } else { 2 * x + y };
        let triangles = (0..n)
            .flat_map(|x| {
                let right = x >= 1;
                let [a, b, c, d] = [at(x, 0, right), at(x + 1, 0, false), at(x + 1, 1, false), at(x, 1, right)];
                [[a, b, c], [a, c, d]]
            })
            .collect();
        Mesh::new(positions, triangles).unwrap()
    }

    #[test]
    fn a_cut_seam_is_joined_and_coincident_parts_are_not() {
        let whole = strip(3, false);
        let mut cut = strip(3, true);
        assert_eq!(validate(&cut).boundary_edges, validate(&whole).boundary_edges + 2);
        assert_eq!(cut.join_cut_seams(), 2);
        assert_eq!((cut.positions.clone(), cut.triangles.clone()), (whole.positions.clone(), whole.triangles.clone()));
        // A copy of the strip lying on it, facing the same way: its borders run the same ways as the
        // strip's, so nothing is joined (joined, every edge would have two faces one way).
        let mut stacked = whole.clone();
        let offset = whole.vertex_count() as u32;
        stacked.positions.extend(whole.positions.clone());
        stacked.triangles.extend(whole.triangles.iter().map(|t| t.map(|v| v + offset)));
        assert_eq!(stacked.join_cut_seams(), 0);
        // Facing the other way, its rim is the other side of the strip's: a closed flat shell.
        let mut shell = stacked.clone();
        for t in &mut shell.triangles[whole.face_count()..] {
            t.swap(1, 2);
        }
        assert_eq!(shell.join_cut_seams(), whole.vertex_count());
        let report = validate(&shell);
        assert_eq!((report.boundary_edges, report.inconsistently_oriented_edges), (0, 0));
        // Three borders between the same two positions: which two are one edge is not known.
        let mut three = strip(1, false);
        three.positions.extend([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-1.0, 0.5, 0.0]]);
        three.positions.extend([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-1.0, 0.5, 1.0]]);
        three.triangles.extend([[4, 6, 5], [7, 9, 8]]);
        assert_eq!(three.join_cut_seams(), 0);
    }

    #[test]
    fn a_pole_of_copies_and_unused_copies_are_joined() {
        // A fan around the origin whose every face has its own copy of the centre, as a UV
        // sphere's pole comes: border edges of zero length between the copies' faces.
        let n = 6;
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for k in 0..n {
            let angle = std::f32::consts::TAU * k as f32 / n as f32;
            positions.push([angle.cos(), angle.sin(), 0.0]);
        }
        for k in 0..n {
            positions.push([0.0, 0.0, 0.0]);
            // The face of the copy k, and a sliver of zero area joining it to the next copy.
            triangles.push([n + k, k, (k + 1) % n]);
            triangles.push([n + k, (k + 1) % n, n + (k + 1) % n]);
        }
        positions.push([1.0, 0.0, 0.0]); // used by no face
        let mut pole = Mesh::new(positions, triangles).unwrap();
        assert_eq!(pole.join_cut_seams(), n as usize);
        assert_eq!(pole.vertex_count(), n as usize + 1);
        // The slivers now repeat the centre; the fan is a closed disk around it.
        assert!(pole.triangles.iter().filter(|t| t[0] == t[2]).count() == n as usize);
    }
}
