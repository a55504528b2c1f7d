//! Validation report and cleaning.
//!
//! `validate` looks at a mesh as it is and counts what later algorithms care about; `clean` repairs
//! what can be repaired without guessing (exact duplicates and degenerate faces) and leaves the rest
//! (non-manifold edges and vertices, holes) to be reported and handled by the algorithms.

use serde::Serialize;

use crate::mesh::{Bounds, Mesh};
use crate::topology::{NO_EDGE, Topology, UnionFind};

/// What [`validate`] found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MeshReport {
    /// Number of vertices (including unreferenced ones).
    pub vertices: usize,
    /// Number of triangles.
    pub faces: usize,
    /// Bounding box of all vertices (zeros for an empty mesh).
    pub bbox_min: [f64; 3],
    /// See `bbox_min`.
    pub bbox_max: [f64; 3],
    /// Length of the bounding-box diagonal.
    pub bbox_diagonal: f64,
    /// Faces that repeat a vertex index or have zero area.
    pub degenerate_faces: usize,
    /// Of those, faces that repeat a vertex index.
    pub repeated_index_faces: usize,
    /// Faces whose vertex set equals an earlier face's (each extra copy counts once).
    pub duplicate_faces: usize,
    /// Vertices no face uses.
    pub unreferenced_vertices: usize,
    /// Edges shared by one face.
    pub boundary_edges: usize,
    /// Closed chains of boundary edges (holes and outer borders), and open chains of them that end
    /// at non-manifold edges, each counted once.
    pub boundary_loops: usize,
    /// Edges shared by more than two faces.
    pub non_manifold_edges: usize,
    /// Vertices whose faces form more than one fan (bowties), or that lie on a non-manifold edge.
    pub non_manifold_vertices: usize,
    /// Pieces of surface connected through shared vertices.
    pub components: usize,
    /// Two-face edges that both faces traverse in the same direction.
    pub inconsistently_oriented_edges: usize,
    /// Whether the mesh is edge-manifold, vertex-manifold and consistently oriented.
    pub is_manifold_oriented: bool,
    /// Euler characteristic V − E + F over referenced vertices.
    pub euler_characteristic: i64,
    /// Per-corner attributes the mesh carries ("normal", "uv", "color"), besides positions.
    pub attributes: Vec<String>,
    /// Two-face edges whose faces carry different attributes at one of its ends (texture seams,
    /// hard normals, colour borders).
    pub seam_edges: usize,
    /// glTF point and line primitives carried beside the triangles
    /// ([`crate::mesh::MaterialLibrary::other_primitives`]).
    pub point_and_line_primitives: usize,
}

/// Counts what a mesh has.
pub fn validate(mesh: &Mesh) -> MeshReport {
    let topology = Topology::new(mesh);
    let tris = &mesh.triangles;

    let mut repeated_index_faces = 0;
    let mut degenerate_faces = 0;
    for (f, t) in tris.iter().enumerate() {
        let repeated = t[0] == t[1] || t[1] == t[2] || t[0] == t[2];
        repeated_index_faces += repeated as usize;
        degenerate_faces += (repeated || mesh.face_area_vector(f).length_squared() == 0.0) as usize;
    }

    let mut sorted: Vec<[u32; 3]> = tris
        .iter()
        .map(|t| {
            let mut s = *t;
            s.sort_unstable();
            s
        })
        .collect();
    sorted.sort_unstable();
    let duplicate_faces = sorted.windows(2).filter(|w| w[0] == w[1]).count();

    let referenced: Vec<bool> = (0..mesh.vertex_count()).map(|v| !topology.vertex_faces.get(v).is_empty()).collect();
    let unreferenced_vertices = referenced.iter().filter(|&&r| !r).count();

    let mut boundary_edges = 0;
    let mut non_manifold_edges = 0;
    let mut on_non_manifold_edge = vec![false; mesh.vertex_count()];
    let mut inconsistently_oriented_edges = 0;
    let mut seam_edges = 0;
    // The corner of face f at vertex v.
    let corner = |f: usize, v: u32| 3 * f + tris[f].iter().position(|&x| x == v).expect("v is a corner of f");
    for (e, &[a, b]) in topology.edges.iter().enumerate() {
        let faces = topology.edge_faces.get(e);
        match faces.len() {
            1 => boundary_edges += 1,
            2 => {
                let (f, g) = (faces[0].index(), faces[1].index());
                if !mesh.corners.is_empty()
                    && (!mesh.corners.same(corner(f, a), corner(g, a))
                        || !mesh.corners.same(corner(f, b), corner(g, b)))
                {
                    seam_edges += 1;
                }
                let forward = |f: usize| {
                    let t = tris[f];
                    (0..3).any(|i| t[i] == a && t[(i + 1) % 3] == b)
                };
                if forward(faces[0].index()) == forward(faces[1].index()) {
                    inconsistently_oriented_edges += 1;
                }
            }
            _ => {
                non_manifold_edges += 1;
                on_non_manifold_edge[a as usize] = true;
                on_non_manifold_edge[b as usize] = true;
            }
        }
    }

    let non_manifold_vertices = (0..mesh.vertex_count())
        .filter(|&v| on_non_manifold_edge[v] || fan_count(mesh, &topology, v as u32) > 1)
        .count();

    let boundary_loops = count_boundary_loops(&topology);

    let components = component_count(mesh, &referenced);

    let bounds = mesh.bounds().unwrap_or(Bounds { min: [0.0; 3], max: [0.0; 3] });
    let referenced_count = (mesh.vertex_count() - unreferenced_vertices) as i64;
    MeshReport {
        vertices: mesh.vertex_count(),
        faces: mesh.face_count(),
        bbox_min: bounds.min,
        bbox_max: bounds.max,
        bbox_diagonal: bounds.diagonal(),
        degenerate_faces,
        repeated_index_faces,
        duplicate_faces,
        unreferenced_vertices,
        boundary_edges,
        boundary_loops,
        non_manifold_edges,
        non_manifold_vertices,
        components,
        inconsistently_oriented_edges,
        is_manifold_oriented: non_manifold_edges == 0
            && non_manifold_vertices == 0
            && inconsistently_oriented_edges == 0,
        euler_characteristic: referenced_count - topology.edges.len() as i64 + tris.len() as i64,
        attributes: mesh.corners.names().into_iter().map(String::from).collect(),
        seam_edges,
        point_and_line_primitives: mesh.corners.library.as_ref().map_or(0, |l| l.other_primitives.len()),
    }
}

/// Number of connected components (through shared vertices) among the `referenced` vertices.
fn component_count(mesh: &Mesh, referenced: &[bool]) -> usize {
    let mut sets = UnionFind::new(mesh.vertex_count());
    for t in &mesh.triangles {
        sets.union(t[0], t[1]);
        sets.union(t[1], t[2]);
    }
    let mut roots: Vec<u32> =
        (0..mesh.vertex_count() as u32).filter(|&v| referenced[v as usize]).map(|v| sets.find(v)).collect();
    roots.sort_unstable();
    roots.dedup();
    roots.len()
}

/// Number of fans (groups of faces connected through edges at `v`) around a vertex.
pub(crate) fn fan_count(mesh: &Mesh, topology: &Topology, v: u32) -> usize {
    let faces = topology.vertex_faces.get(v as usize);
    if faces.len() <= 1 {
        return faces.len();
    }
    // Label each face with a fan by flood fill across the edges at v; no allocation for the
    // usual valences.
    const INLINE: usize = 64;
    let mut inline = [u32::MAX; INLINE];
    let mut heap_labels;
    let labels: &mut [u32] = if faces.len() <= INLINE {
        &mut inline[..faces.len()]
    } else {
        heap_labels = vec![u32::MAX; faces.len()];
        &mut heap_labels
    };
    let mut fans = 0u32;
    let mut stack: Vec<usize> = Vec::new();
    for start in 0..faces.len() {
        if labels[start] != u32::MAX {
            continue;
        }
        labels[start] = fans;
        stack.clear();
        stack.push(start);
        while let Some(i) = stack.pop() {
            let f = faces[i].index();
            let t = mesh.triangles[f];
            for corner in 0..3 {
                let e = topology.face_edges[f][corner];
                let (a, b) = (t[corner], t[(corner + 1) % 3]);
                if e == NO_EDGE || (a != v && b != v) {
                    continue;
                }
                for g in topology.edge_faces.get(e as usize) {
                    // The faces at v are in face order: found in O(log valence), so a hub vertex
                    // costs O(valence · log valence), not its square.
                    if let Ok(j) = faces.binary_search_by_key(&g.index(), |h| h.index())
                        && labels[j] == u32::MAX
                    {
                        labels[j] = fans;
                        stack.push(j);
                    }
                }
            }
        }
        fans += 1;
    }
    fans as usize
}

/// Counts boundary loops: closed walks over the boundary edges (edges with one face), and the
/// open chains of them that end at non-manifold edges.
///
/// The walk follows the edges whichever way their faces run, so a loop along which the
/// orientation flips (a strip of faces turned over) is one loop, not one per start. At a vertex
/// with two boundary edges it goes on along the other one. At a vertex where several loops touch
/// (pinched, non-manifold) it leaves along the boundary edge of the same fan as the one it arrived
/// by, found by turning around the vertex through its faces; where that turn is not defined (an
/// edge with more than two faces) along any unused boundary edge there. The count does not depend
/// on the order of the vertices or faces, except where such an undefined turn leaves a choice.
fn count_boundary_loops(topology: &Topology) -> usize {
    let on_boundary = |e: u32| topology.edge_faces.get(e as usize).len() == 1;
    let boundary: Vec<u32> = (0..topology.edges.len() as u32).filter(|&e| on_boundary(e)).collect();
    let vertex_count = topology.vertex_faces.len();
    let at_vertex = crate::topology::Csr::from_pairs(
        vertex_count,
        boundary.iter().flat_map(|&e| topology.edges[e as usize].map(|v| (v as usize, e))),
    );
    let mut used = vec![false; topology.edges.len()];
    // The other edge at `v` of the face whose edge at `v` is `e`.
    let other_edge_at = |face: usize, e: u32, v: u32| -> Option<u32> {
        let t = topology.face_edges[face];
        (0..3).map(|k| t[k]).find(|&x| x != e && x != NO_EDGE && topology.edges[x as usize].contains(&v))
    };
    // The boundary edge of the fan at `v` that `e` (a boundary edge at `v`) bounds on its other
    // side: turn from `e`'s face across the edges at `v` with two faces.
    let turn = |e: u32, v: u32| -> Option<u32> {
        let mut face = topology.edge_faces.get(e as usize)[0].index();
        let mut from = e;
        for _ in 0..=topology.vertex_faces.get(v as usize).len() {
            let next = other_edge_at(face, from, v)?;
            match topology.edge_faces.get(next as usize) {
                [_] => return Some(next),
                [f, g] => {
                    face = if f.index() == face { g.index() } else { f.index() };
                    from = next;
                }
                _ => return None,
            }
        }
        None
    };
    let mut loops = 0;
    for &start in &boundary {
        if used[start as usize] {
            continue;
        }
        loops += 1;
        // Out from both ends of the first edge: a closed loop comes back to it (and the second
        // walk stops at once); a chain that ends at a non-manifold edge is one piece, wherever
        // in it the walk starts.
        for end in topology.edges[start as usize] {
            let (mut e, mut v) = (start, end);
            loop {
                used[e as usize] = true;
                let here = at_vertex.get(v as usize);
                let next = match here {
                    [x, y] => Some(if *x == e { *y } else { *x }),
                    _ => turn(e, v).or_else(|| here.iter().copied().find(|&x| !used[x as usize])),
                };
                match next.filter(|&n| !used[n as usize]) {
                    Some(n) => {
                        let [a, b] = topology.edges[n as usize];
                        (e, v) = (n, if a == v { b } else { a });
                    }
                    None => break,
                }
            }
        }
    }
    loops
}

/// What [`clean`] changed.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize)]
pub struct CleanReport {
    /// Vertices merged into an earlier vertex at exactly the same position.
    pub welded_vertices: usize,
    /// Faces dropped because they repeat a vertex (after welding) or have zero area.
    pub removed_degenerate_faces: usize,
    /// Faces dropped because an earlier face has the same vertex set.
    pub removed_duplicate_faces: usize,
    /// Vertices dropped because no face uses them.
    pub removed_unreferenced_vertices: usize,
}

/// Welds exactly coincident vertices, drops degenerate and duplicate faces, and drops unreferenced
/// vertices. Vertex and face order are otherwise kept. Per-corner attributes follow their faces.
pub fn clean(mesh: &Mesh) -> (Mesh, CleanReport) {
    let mut report = CleanReport::default();
    // Weld: first vertex at a position wins. -0.0 and 0.0 are the same position.
    let weld = mesh.first_at_each_position();
    report.welded_vertices = weld.iter().enumerate().filter(|&(v, &w)| v as u32 != w).count();

    let mut seen: std::collections::HashSet<[u32; 3]> = std::collections::HashSet::with_capacity(mesh.face_count());
    let mut kept_faces = Vec::with_capacity(mesh.face_count());
    for (f, t) in mesh.triangles.iter().enumerate() {
        let w = t.map(|v| weld[v as usize]);
        if w[0] == w[1] || w[1] == w[2] || w[0] == w[2] || mesh.face_area_vector(f).length_squared() == 0.0 {
            report.removed_degenerate_faces += 1;
            continue;
        }
        let mut sorted = w;
        sorted.sort_unstable();
        if !seen.insert(sorted) {
            report.removed_duplicate_faces += 1;
            continue;
        }
        kept_faces.push((f, w));
    }

    let mut new_index = vec![u32::MAX; mesh.vertex_count()];
    let mut positions = Vec::new();
    for &(_, w) in &kept_faces {
        for v in w {
            if new_index[v as usize] == u32::MAX {
                new_index[v as usize] = u32::MAX - 1; // mark referenced; numbered below in vertex order
            }
        }
    }
    for (v, slot) in new_index.iter_mut().enumerate() {
        if *slot != u32::MAX {
            *slot = positions.len() as u32;
            positions.push(mesh.positions[v]);
        }
    }
    report.removed_unreferenced_vertices = mesh.vertex_count() - report.welded_vertices - positions.len();
    let triangles = kept_faces.iter().map(|&(_, w)| w.map(|v| new_index[v as usize])).collect();
    let kept: Vec<usize> = kept_faces.iter().map(|&(f, _)| f).collect();
    let corners = mesh.corners.pick(kept.iter().flat_map(|&f| [3 * f, 3 * f + 1, 3 * f + 2]));
    let cleaned = Mesh { positions, triangles, corners };
    debug_assert!(cleaned.check().is_ok());
    (cleaned, report)
}
