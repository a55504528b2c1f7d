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

/// Marks a face corner whose edge is not part of the edge table (the face repeats a vertex).
pub const NO_EDGE: u32 = u32::MAX;

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
