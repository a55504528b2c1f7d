//! Preparation and classification: drop faces that repeat a vertex, then one pass over the fans
//! classifies every vertex (interior, boundary, frozen) and lists the edges. With per-corner
//! attributes, [`State::relax`] lets go of an anchor or a seam vertex once collapses have taken
//! its sets of values down far enough.

use std::borrow::Cow;

use crate::fan::{Corner, FAN_INLINE, FanSlot};
use crate::mesh::Mesh;

use super::vertex::{NONE, VertexKind};

/// Fans up to this many faces are scanned by counting ([`scan_small_fan`]); larger ones by sorting.
pub(super) const SMALL_FAN: usize = 16;

/// [`prepare`], borrowing the mesh itself when there is nothing to drop (the usual input); the
/// input index of each vertex is then the identity.
pub(super) fn prepare_in_place(mesh: &Mesh) -> (Cow<'_, Mesh>, Vec<u32>, usize) {
    let repeats_a_vertex = |t: &[u32; 3]| t[0] == t[1] || t[1] == t[2] || t[0] == t[2];
    let mut new_index = vec![NONE; mesh.vertex_count()];
    let mut dropped = 0;
    for t in &mesh.triangles {
        if repeats_a_vertex(t) {
            dropped += 1;
            continue;
        }
        for &v in t {
            new_index[v as usize] = 0;
        }
    }
    let mut input_vertex = Vec::with_capacity(mesh.vertex_count());
    for (v, slot) in new_index.iter_mut().enumerate() {
        if *slot != NONE {
            *slot = input_vertex.len() as u32;
            input_vertex.push(v as u32);
        }
    }
    if dropped == 0 && input_vertex.len() == mesh.vertex_count() {
        return (Cow::Borrowed(mesh), input_vertex, 0);
    }
    let positions = input_vertex.iter().map(|&v| mesh.positions[v as usize]).collect();
    let kept = (0..mesh.face_count()).filter(|&f| !repeats_a_vertex(&mesh.triangles[f]));
    let triangles = kept.clone().map(|f| mesh.triangles[f].map(|v| new_index[v as usize])).collect();
    let corners = mesh.corners.pick(kept.flat_map(|f| [3 * f, 3 * f + 1, 3 * f + 2]));
    (Cow::Owned(Mesh { positions, triangles, corners }), input_vertex, dropped)
}

/// [`prepare`] keeping the per-corner attributes.
pub(crate) fn prepare_with_attributes(mesh: &Mesh) -> Mesh {
    prepare_in_place(mesh).0.into_owned()
}

/// Drops faces that repeat a vertex and vertices that no face uses. Returns the prepared mesh
/// (without per-corner attributes: the public form, for the progressive mesh), the input index of each kept vertex, and the number of
/// dropped faces.
pub fn prepare(mesh: &Mesh) -> (Mesh, Vec<u32>, usize) {
    let (prepared, input_vertex, dropped) = prepare_in_place(mesh);
    let prepared = match prepared {
        Cow::Borrowed(m) => {
            Mesh { positions: m.positions.clone(), triangles: m.triangles.clone(), corners: Default::default() }
        }
        Cow::Owned(m) => Mesh { corners: Default::default(), ..m },
    };
    (prepared, input_vertex, dropped)
}

/// What one pass over the fans finds.
pub(super) struct Scan {
    pub(super) kind: Vec<VertexKind>,
    /// Every undirected edge once, `[low, high]`, sorted.
    pub(super) edges: Vec<[u32; 2]>,
    /// Edges with one face: `(low, high, face)`, sorted.
    pub(super) boundary_edges: Vec<(u32, u32, u32)>,
}

/// Classifies every vertex from its fan: an edge with one face makes its ends boundary vertices;
/// an edge with more than two faces, or two faces that disagree on orientation, and a vertex whose
/// faces form more than one fan (two surface sheets touching at a point) make it frozen. Each
/// vertex looks only at its own fan (both ends of an edge see the same faces, so they agree).
/// Fans of the usual size are scanned by counting ([`scan_small_fan`]); a hub vertex by sorting
/// ([`scan_large_fan`]), so that the time stays O(valence · log valence).
///
/// Blocks of vertices may be scanned side by side ([`crate::parallel`]); their finds are joined in
/// vertex order: the same lists as one pass.
pub(super) fn scan_fans(fans: &[FanSlot]) -> Scan {
    const BLOCK: usize = 8192;
    let blocks = crate::parallel::map_blocks(fans, BLOCK, |i, block| scan_block(block, (i * BLOCK) as u32));
    let mut scan = Scan {
        kind: Vec::with_capacity(fans.len()),
        edges: Vec::with_capacity(blocks.iter().map(|b| b.edges.len()).sum()),
        boundary_edges: Vec::new(),
    };
    for block in blocks {
        scan.kind.extend(block.kind);
        scan.edges.extend(block.edges);
        scan.boundary_edges.extend(block.boundary_edges);
    }
    scan
}

/// [`scan_fans`] over the fans of vertices `first..`.
fn scan_block(fans: &[FanSlot], first: u32) -> Scan {
    let mut scan = Scan { kind: Vec::with_capacity(fans.len()), edges: Vec::new(), boundary_edges: Vec::new() };
    let mut scratch = LargeFanScratch::default();
    for (v, fan) in (first..).zip(fans) {
        let closed = fan.inline_slots().and_then(|slots| scan_closed_fan(v, slots, fan.len(), &mut scan));
        let kind = match (closed, fan.len()) {
            (Some(kind), _) => kind,
            (None, 0..=SMALL_FAN) => scan_small_fan(v, fan, &mut scan),
            (None, _) => scan_large_fan(v, fan, &mut scan, &mut scratch),
        };
        scan.kind.push(kind);
    }
    scan
}

/// [`scan_fans`] for the usual vertex: an inline fan (the slots past `n` padded with
/// [`Corner::NONE`]) whose faces close around it, each `next` neighbour being exactly one face's
/// `prev`. Then the only question is whether the faces form one cycle or several (two cones
/// touching at the vertex), and the neighbours are the `next` corners. `None` when the fan is not
/// closed in this way (a boundary, a non-manifold edge): [`scan_small_fan`] sorts those out.
///
/// Every slot is compared with every other (fixed bounds, no branch on the data): a fraction of the
/// instructions of the general count (docs/history/benchmarks-log.md).
fn scan_closed_fan(v: u32, slots: &[Corner; FAN_INLINE], n: usize, scan: &mut Scan) -> Option<VertexKind> {
    const N: usize = FAN_INLINE;
    if n < 2 {
        return None;
    }
    let live = (1u32 << n) - 1;
    let next = slots.map(|c| c.next);
    let prev = slots.map(|c| c.prev);
    // after[i]: the face whose `prev` is face i's `next` (the face that follows i around v).
    let mut after = [0u8; N];
    let mut closed = true;
    let mut followed = 0u32;
    for i in 0..N {
        let mut followers = 0u32;
        for (j, &p) in prev.iter().enumerate() {
            followers |= ((p == next[i]) as u32) << j;
        }
        followers &= live;
        let exactly_one = (followers != 0) & (followers & followers.wrapping_sub(1) == 0);
        closed &= (i >= n) | (exactly_one & (next[i] != v) & (prev[i] != v));
        followed |= followers;
        after[i] = followers.trailing_zeros().min(N as u32 - 1) as u8;
    }
    // Each `next` has exactly one follower and every face follows one: the follower map is a
    // permutation, so the `next` corners are distinct and are exactly the `prev` corners.
    if !closed || followed != live {
        return None;
    }
    // Every edge has two faces, one each way, and the neighbours are the `next` corners: those
    // above v, sorted by a network over all slots (the rest set to NONE), are its edges.
    let mut upper = next.map(|x| if x > v { x } else { NONE });
    for (i, slot) in upper.iter_mut().enumerate() {
        if i >= n {
            *slot = NONE;
        }
    }
    sort8(&mut upper);
    let count = upper.iter().filter(|&&x| x != NONE).count();
    scan.edges.extend(upper[..count].iter().map(|&u| [v, u]));
    // One cycle through all n faces, or several: then the vertex joins separate fans.
    let (mut current, mut steps) = (0usize, 0usize);
    loop {
        current = after[current] as usize;
        steps += 1;
        if current == 0 || steps == n {
            break;
        }
    }
    if current != 0 || steps != n {
        return Some(VertexKind::Frozen);
    }
    Some(VertexKind::Interior)
}

/// Sorts eight values with a fixed network of 19 compare-exchanges (no branch on the data), each
/// written out on locals so that they stay in registers.
fn sort8(values: &mut [u32; 8]) {
    let [mut v0, mut v1, mut v2, mut v3, mut v4, mut v5, mut v6, mut v7] = *values;
    macro_rules! exchange {
        ($x:ident, $y:ident) => {
            let (lo, hi) = ($x.min($y), $x.max($y));
            $x = lo;
            $y = hi;
        };
    }
    exchange!(v0, v2);
    exchange!(v1, v3);
    exchange!(v4, v6);
    exchange!(v5, v7);
    exchange!(v0, v4);
    exchange!(v1, v5);
    exchange!(v2, v6);
    exchange!(v3, v7);
    exchange!(v0, v1);
    exchange!(v2, v3);
    exchange!(v4, v5);
    exchange!(v6, v7);
    exchange!(v2, v4);
    exchange!(v3, v5);
    exchange!(v1, v4);
    exchange!(v3, v6);
    exchange!(v1, v2);
    exchange!(v3, v4);
    exchange!(v5, v6);
    *values = [v0, v1, v2, v3, v4, v5, v6, v7];
}

/// [`scan_fans`] for one fan of at most [`SMALL_FAN`] faces. Every corner's two edges are counted
/// against all corners at once, without a branch on the data: the edge (v, u) is manifold when
/// exactly one face runs v → u and at most one u → v; it is a boundary edge when it has one face.
/// Sorting the corner ends instead, as [`scan_large_fan`] does, mispredicts about a branch per
/// comparison and took about twice the time (docs/history/benchmarks-log.md).
/// Out of line, so that there is one copy of the vectorised count loop.
#[inline(never)]
fn scan_small_fan(v: u32, fan: &[Corner], scan: &mut Scan) -> VertexKind {
    const N: usize = SMALL_FAN;
    let n = fan.len();
    debug_assert!(n <= N);
    // Padding never matches: NONE is no vertex.
    let (mut next, mut prev) = ([NONE; N], [NONE; N]);
    for (i, c) in fan.iter().enumerate() {
        next[i] = c.next;
        prev[i] = c.prev;
    }
    let mut frozen = false;
    let mut on_boundary = false;
    // The first face whose `prev` edge no other face shares: where an open fan starts.
    let mut open_start = NONE as usize;
    // Neighbours above v (each edge is listed by its lower end), and the boundary edges among them.
    // Written unconditionally, kept by advancing the count: no branch on the data.
    let mut upper = [NONE; 2 * N];
    let mut upper_count = 0;
    let mut boundary = [(NONE, NONE); 2 * N];
    let mut boundary_count = 0;
    // Per face i, counted over all faces k at once (lane i of each array, so the loop runs on
    // vectors): faces running v → x and x → v, where x is i's `next`; v → y and y → v, where y is
    // its `prev`; and the face after i around v (whose `prev` is x), meaningful when there is one.
    let (mut out_x, mut in_x, mut out_y, mut in_y, mut after) = ([0u32; N], [0u32; N], [0u32; N], [0u32; N], [0u32; N]);
    // Only the groups of four lanes that hold faces (two for the usual valence).
    let groups = n.div_ceil(4).min(N / 4);
    for k in 0..n {
        let (x, y) = (next[k], prev[k]);
        for group in 0..groups {
            for i in 4 * group..4 * group + 4 {
                let follows = ((next[i] == y) as u32).wrapping_neg();
                out_x[i] += (next[i] == x) as u32;
                in_x[i] += follows & 1;
                after[i] |= follows & k as u32;
                out_y[i] += (prev[i] == x) as u32;
                in_y[i] += (prev[i] == y) as u32;
            }
        }
    }
    for i in 0..n {
        let (x, y, face) = (next[i], prev[i], fan[i].face);
        let (out_x, in_x, out_y, in_y) = (out_x[i], in_x[i], out_y[i], in_y[i]);
        frozen |= (x == v) | (y == v) | (out_x > 1) | (in_x > 1) | (out_y > 1) | (in_y > 1);
        open_start = if out_y == 0 && open_start == NONE as usize { i } else { open_start };
        // Edge (v, x) has this face alone when no other face names x; likewise (v, y).
        let x_alone = (out_x == 1) & (in_x == 0) & (x != v);
        let y_alone = (in_y == 1) & (out_y == 0) & (y != v);
        on_boundary |= x_alone | y_alone;
        upper[upper_count] = x;
        upper_count += (x > v) as usize;
        boundary[boundary_count] = (x, face);
        boundary_count += ((x > v) & x_alone) as usize;
        // y is listed here only when no face runs v → y (then it was listed as some face's x).
        upper[upper_count] = y;
        upper_count += ((y > v) & (out_y == 0)) as usize;
        boundary[boundary_count] = (y, face);
        boundary_count += ((y > v) & y_alone) as usize;
    }
    // A handful of values: insertion sort. Repeats only where a face pair repeats (frozen).
    let upper = &mut upper[..upper_count];
    insertion_sort(upper);
    let mut last = NONE;
    for &u in upper.iter() {
        if u != last {
            scan.edges.push([v, u]);
            last = u;
        }
    }
    let boundary = &mut boundary[..boundary_count];
    insertion_sort(boundary);
    scan.boundary_edges.extend(boundary.iter().map(|&(u, face)| (v, u, face)));
    if frozen {
        return VertexKind::Frozen;
    }
    // One fan: walking from face to face across shared edges, from the open end if there is one,
    // reaches every face.
    let start = if open_start == NONE as usize { 0 } else { open_start };
    let (mut current, mut reached) = (start, 1);
    while n > 1 && in_x[current] == 1 {
        let next_face = after[current] as usize;
        if next_face == start || reached == n {
            break;
        }
        current = next_face;
        reached += 1;
    }
    if reached < n {
        VertexKind::Frozen
    } else if on_boundary {
        VertexKind::Boundary
    } else {
        VertexKind::Interior
    }
}

/// Sorts a few values (a fan's neighbours above its vertex: about three).
fn insertion_sort<T: Copy + Ord>(values: &mut [T]) {
    for i in 1..values.len() {
        let x = values[i];
        let mut j = i;
        while j > 0 && values[j - 1] > x {
            values[j] = values[j - 1];
            j -= 1;
        }
        values[j] = x;
    }
}

/// Reused buffers of [`scan_large_fan`].
#[derive(Default)]
pub(super) struct LargeFanScratch {
    ends: Vec<u64>,
    by_next: Vec<(u32, u32)>,
    by_prev: Vec<(u32, u32)>,
}

/// [`scan_fans`] for a fan of any size, by sorting its corner ends.
fn scan_large_fan(v: u32, fan: &[Corner], scan: &mut Scan, scratch: &mut LargeFanScratch) -> VertexKind {
    // Both edges of each corner, packed to sort as one integer: neighbour (high bits), whether the
    // face runs v → neighbour (bit 32), face (low 32 bits).
    const OUTGOING: u64 = 1 << 32;
    let ends = &mut scratch.ends;
    ends.clear();
    ends.extend(
        fan.iter().flat_map(|c| {
            [((c.next as u64) << 33) | OUTGOING | c.face as u64, ((c.prev as u64) << 33) | c.face as u64]
        }),
    );
    ends.sort_unstable();
    let mut frozen = false;
    let mut on_boundary = false;
    for group in ends.chunk_by(|x, y| x >> 33 == y >> 33) {
        let u = (group[0] >> 33) as u32;
        match group {
            _ if u == v => frozen = true,
            [end] => {
                on_boundary = true;
                if v < u {
                    scan.boundary_edges.push((v, u, *end as u32));
                }
            }
            [x, y] if (x ^ y) & OUTGOING != 0 => {}
            _ => frozen = true,
        }
        if v < u {
            scan.edges.push([v, u]);
        }
    }
    if frozen || !single_fan(fan, &mut scratch.by_next, &mut scratch.by_prev) {
        VertexKind::Frozen
    } else if on_boundary {
        VertexKind::Boundary
    } else {
        VertexKind::Interior
    }
}

/// Whether the faces around a vertex (all of whose edges are manifold) form one fan: walking from
/// face to face across shared edges, starting at a face with a free edge if there is one, reaches
/// every face. Through sorted indices, to stay O(n log n) on a hub vertex.
fn single_fan(fan: &[Corner], by_next: &mut Vec<(u32, u32)>, by_prev: &mut Vec<(u32, u32)>) -> bool {
    let n = fan.len();
    if n <= 1 {
        return true;
    }
    // The face after face i shares the edge (v, i.next) as its `prev` edge.
    by_next.clear();
    by_next.extend(fan.iter().enumerate().map(|(i, c)| (c.next, i as u32)));
    by_next.sort_unstable();
    by_prev.clear();
    by_prev.extend(fan.iter().enumerate().map(|(i, c)| (c.prev, i as u32)));
    by_prev.sort_unstable();
    let find = |index: &[(u32, u32)], key: u32| {
        let j = index.partition_point(|e| e.0 < key);
        (j < index.len() && index[j].0 == key).then(|| index[j].1 as usize)
    };
    // A face whose `prev` edge no other face shares starts an open fan.
    let start = (0..n).find(|&i| find(by_next, fan[i].prev).is_none()).unwrap_or(0);
    let mut current = start;
    let mut reached = 1;
    while let Some(next) = find(by_prev, fan[current].next) {
        if next == start || reached == n {
            break;
        }
        current = next;
        reached += 1;
    }
    reached == n
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::procedural;
    use crate::simplify::SimplifyOptions;
    use crate::simplify::kernel::State;
    use crate::topology::Topology;

    /// The classification from the edge table (sorted half-edges) and the validator's fan count:
    /// an independent route to what [`scan_fans`] finds from the fans alone.
    type Classification = (Vec<VertexKind>, Vec<[u32; 2]>, Vec<(u32, u32)>);

    fn reference_kinds(mesh: &Mesh) -> Classification {
        let topology = Topology::new(mesh);
        let mut kind = vec![VertexKind::Interior; mesh.vertex_count()];
        let mut boundary = Vec::new();
        for (e, &[a, b]) in topology.edges.iter().enumerate() {
            let faces = topology.edge_faces.get(e);
            let k = match faces.len() {
                1 => {
                    boundary.push((a, b));
                    VertexKind::Boundary
                }
                2 => {
                    let forward = |f: usize| {
                        let t = mesh.triangles[f];
                        (0..3).any(|i| t[i] == a && t[(i + 1) % 3] == b)
                    };
                    if forward(faces[0].index()) == forward(faces[1].index()) {
                        VertexKind::Frozen
                    } else {
                        continue;
                    }
                }
                _ => VertexKind::Frozen,
            };
            for v in [a, b] {
                if kind[v as usize] != VertexKind::Frozen {
                    kind[v as usize] = k;
                }
            }
        }
        for (v, k) in kind.iter_mut().enumerate() {
            if *k != VertexKind::Frozen && crate::validate::fan_count(mesh, &topology, v as u32) > 1 {
                *k = VertexKind::Frozen;
            }
        }
        (kind, topology.edges.clone(), boundary)
    }

    fn assert_scan_matches(name: &str, mesh: &Mesh) {
        let (mesh, _, _) = prepare(mesh);
        let options = SimplifyOptions::default();
        let (state, edges) = State::new(&mesh, &options);
        let (kind, reference_edges, reference_boundary) = reference_kinds(&mesh);
        let classes: Vec<VertexKind> = state.vertices.iter().map(|v| v.kind).collect();
        assert_eq!(classes, kind, "{name}: vertex classes");
        assert_eq!(edges, reference_edges, "{name}: edge list");
        let Scan { boundary_edges, .. } = scan_fans(&state.topo.fans);
        let boundary: Vec<(u32, u32)> = boundary_edges.iter().map(|&(a, b, _)| (a, b)).collect();
        assert_eq!(boundary, reference_boundary, "{name}: boundary edges");
    }

    /// The counting scan of small fans and the sorting scan agree on every vertex: class, edges and
    /// boundary edges with their faces, in order.
    fn assert_small_scan_matches_large(name: &str, mesh: &Mesh) {
        let (mesh, _, _) = prepare(mesh);
        let options = SimplifyOptions::default();
        let (state, _) = State::new(&mesh, &options);
        let mut scratch = LargeFanScratch::default();
        let empty = || Scan { kind: Vec::new(), edges: Vec::new(), boundary_edges: Vec::new() };
        for (v, fan) in state.topo.fans.iter().enumerate().filter(|(_, fan)| fan.len() <= SMALL_FAN) {
            let (mut small, mut large) = (empty(), empty());
            let small_kind = scan_small_fan(v as u32, fan, &mut small);
            let large_kind = scan_large_fan(v as u32, fan, &mut large, &mut scratch);
            assert_eq!(small_kind, large_kind, "{name}: class of vertex {v}");
            assert_eq!(small.edges, large.edges, "{name}: edges of vertex {v}");
            assert_eq!(small.boundary_edges, large.boundary_edges, "{name}: boundary edges of vertex {v}");
            // The closed-fan scan, where it answers, answers as the counting scan does.
            if let Some(slots) = fan.inline_slots() {
                let mut closed = empty();
                if let Some(closed_kind) = scan_closed_fan(v as u32, slots, fan.len(), &mut closed) {
                    assert_eq!(closed_kind, small_kind, "{name}: closed-fan class of vertex {v}");
                    assert_eq!(closed.edges, small.edges, "{name}: closed-fan edges of vertex {v}");
                    assert!(small.boundary_edges.is_empty(), "{name}: vertex {v} has boundary edges");
                } else {
                    assert!(
                        small_kind != VertexKind::Interior || fan.len() < 2,
                        "{name}: interior vertex {v} left to the counting scan"
                    );
                }
            }
        }
    }

    #[test]
    fn fan_scan_agrees_with_the_edge_table() {
        // Closed, open, and the three kinds of trouble: two sheets touching at a vertex, an edge
        // with three faces, a face turned the wrong way.
        let square = |positions: Vec<[f32; 3]>, triangles: Vec<[u32; 3]>| Mesh {
            positions,
            triangles,
            corners: Default::default(),
        };
        let p = |x: f32, y: f32, z: f32| [x, y, z];
        let bowtie = square(
            vec![
                p(0., 0., 0.),
                p(1., 0., 0.),
                p(0., 1., 0.),
                p(-1., 0., 0.),
                p(0., -1., 0.),
                p(1., 1., 0.),
                p(-1., -1., 0.),
            ],
            vec![[0, 1, 5], [0, 5, 2], [0, 3, 6], [0, 6, 4]],
        );
        let fin = square(
            vec![p(0., 0., 0.), p(1., 0., 0.), p(0., 1., 0.), p(0., -1., 0.), p(0., 0., 1.)],
            vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]],
        );
        let flipped =
            square(vec![p(0., 0., 0.), p(1., 0., 0.), p(0., 1., 0.), p(1., 1., 0.)], vec![[0, 1, 2], [1, 2, 3]]);
        // A hub: one vertex with more faces than the counting scan takes (the sorting scan's case),
        // closed into a cone by a second hub.
        let ring = 3 * SMALL_FAN as u32;
        let mut hub_positions = vec![p(0., 0., 1.), p(0., 0., -1.)];
        hub_positions.extend((0..ring).map(|i| {
            let t = i as f32 / ring as f32 * std::f32::consts::TAU;
            p(t.cos(), t.sin(), 0.)
        }));
        let hub_faces: Vec<[u32; 3]> = (0..ring).map(|i| [0, 2 + i, 2 + (i + 1) % ring]).collect();
        let mut cone_faces = hub_faces.clone();
        cone_faces.extend((0..ring).map(|i| [1, 2 + (i + 1) % ring, 2 + i]));
        // Two closed cones sharing their apex: each fan at the apex closes, but into two cycles.
        let double_cone = square(
            vec![
                p(0., 0., 0.),
                p(1., 0., 1.),
                p(-1., 1., 1.),
                p(-1., -1., 1.),
                p(1., 0., -1.),
                p(-1., 1., -1.),
                p(-1., -1., -1.),
            ],
            vec![[0, 1, 2], [0, 2, 3], [0, 3, 1], [0, 5, 4], [0, 6, 5], [0, 4, 6], [1, 3, 2], [4, 5, 6]],
        );
        let hub_disc = square(hub_positions.clone(), hub_faces);
        let hub_cone = square(hub_positions, cone_faces);
        let mut cases: Vec<(String, Mesh)> = vec![
            ("icosphere".into(), procedural::icosphere(3)),
            ("torus".into(), procedural::torus(24, 12, 0.3)),
            ("terrain".into(), procedural::terrain(20, 3)),
            ("sharp box".into(), procedural::sharp_box(6)),
            ("bowtie".into(), bowtie),
            ("fin".into(), fin),
            ("flipped".into(), flipped),
            ("hub disc".into(), hub_disc),
            ("hub cone".into(), hub_cone),
            ("double cone".into(), double_cone),
        ];
        if let Some(dir) = crate::datasets::require_shared_meshes("fan_scan_agrees_with_the_edge_table") {
            for name in crate::datasets::SHARED_MESHES {
                let mesh = crate::io::read_mesh(dir.join(format!("{name}.obj"))).expect("shared mesh reads");
                cases.push((name.to_string(), mesh));
            }
        }
        for (name, mesh) in &cases {
            assert_scan_matches(name, mesh);
            assert_small_scan_matches_large(name, mesh);
        }
        let frozen = |mesh: &Mesh| {
            let options = SimplifyOptions::default();
            let (state, _) = State::new(mesh, &options);
            (0..mesh.vertex_count()).filter(|&v| state.vertices[v].kind == VertexKind::Frozen).collect::<Vec<_>>()
        };
        assert_eq!(frozen(&cases[4].1), vec![0], "bowtie centre");
        assert_eq!(frozen(&cases[5].1), vec![0, 1], "fin edge");
        assert_eq!(frozen(&cases[6].1), vec![1, 2], "edge between faces of opposite orientation");
        assert_eq!(frozen(&cases[9].1), vec![0], "apex of two closed cones");
        let options = SimplifyOptions::default();
        let (state, _) = State::new(&cases[9].1, &options);
        let mut scan = Scan { kind: Vec::new(), edges: Vec::new(), boundary_edges: Vec::new() };
        let apex = &state.topo.fans[0];
        assert_eq!(
            scan_closed_fan(0, apex.inline_slots().expect("six faces are inline"), apex.len(), &mut scan),
            Some(VertexKind::Frozen),
            "the closed-fan scan sees the two cycles"
        );
    }

    /// The wheel (centre 0, six faces around it, a ring of twelve outside) with three sets of
    /// values at the centre, each two of its faces and the ring faces beyond them: the sets differ
    /// in their normals, and with `uv_split` in their texture coordinates as well.
    fn wheel_in_three_sets(uv_split: bool) -> Mesh {
        let mut mesh = crate::simplify::legality::tests::wheel();
        // Faces come three per sector k (the centre's, then two ring faces); set k / 2.
        let set = |corner: usize| (corner / 3 / 3 / 2) as f32;
        let at = |corner: usize| mesh.positions[mesh.triangles[corner / 3][corner % 3] as usize];
        let corners = 0..3 * mesh.face_count();
        let uvs = corners.clone().map(|k| [at(k)[0] / 8.0 + if uv_split { set(k) } else { 0.0 }, at(k)[1] / 8.0]);
        let normals = corners.map(|k| {
            let tilt = 0.2 * (set(k) - 1.0);
            let length = (1.0 + tilt * tilt).sqrt();
            [tilt / length, 0.0, 1.0 / length]
        });
        mesh.corners.set_uvs(Some(uvs.collect()));
        mesh.corners.set_normals(Some(normals.collect()));
        mesh
    }

    /// The centre's corners in the faces of `sectors` take its values of sector `from`, as they
    /// would once collapses took the faces of their own set at the centre away.
    fn centre_takes_values(state: &mut State, sectors: &[u32], from: u32) {
        let source = state.source_at(3 * from, 0);
        for &sector in sectors {
            let face = 3 * sector as usize;
            let k = state.topo.triangles[face].iter().position(|&v| v == 0).unwrap();
            state.seams.corner_source[3 * face + k] = source;
        }
    }

    #[test]
    fn relax_releases_hard_edge_anchors_and_takes_one_chart_vertices_off_the_seam() {
        for (uv_split, released) in [(false, true), (true, false)] {
            let mesh = wheel_in_three_sets(uv_split);
            let options = SimplifyOptions::default();
            let (mut state, _) = State::new(&mesh, &options);
            state.carry_attributes(&mesh);
            assert_eq!(state.vertices[0].kind, VertexKind::Anchored, "three sets meet at the centre");
            assert!(!state.relax(0), "all three sets are still there");
            centre_takes_values(&mut state, &[4, 5], 2);
            assert_eq!(state.relax(0), released, "texture coordinates split: {uv_split}");
            if released {
                assert_eq!(state.vertices[0].kind, VertexKind::Interior, "its fan is closed");
                assert!(state.seams.on_seam[0], "still on the edge between its two sets");
            } else {
                assert_eq!(state.vertices[0].kind, VertexKind::Anchored);
            }
        }
        // One set left: it stays.
        let mesh = wheel_in_three_sets(false);
        let options = SimplifyOptions::default();
        let (mut state, _) = State::new(&mesh, &options);
        state.carry_attributes(&mesh);
        centre_takes_values(&mut state, &[1, 2, 3, 4, 5], 0);
        assert!(!state.relax(0));
        // A seam vertex: the centre with two sets, sectors 0-2 against 3-5 (a seam through it).
        let mut halves = crate::simplify::legality::tests::wheel();
        let uvs = (0..3 * halves.face_count())
            .map(|k| {
                let p = halves.positions[halves.triangles[k / 3][k % 3] as usize];
                [p[0] / 8.0 + if k / 9 >= 3 { 1.0 } else { 0.0 }, p[1] / 8.0]
            })
            .collect();
        halves.corners.set_uvs(Some(uvs));
        let options = SimplifyOptions::default();
        let (mut state, _) = State::new(&halves, &options);
        state.carry_attributes(&halves);
        assert_eq!(state.vertices[0].kind, VertexKind::Interior);
        assert!(state.seams.on_seam[0] && !state.relax(0), "two sets: on the seam");
        centre_takes_values(&mut state, &[3, 4, 5], 0);
        assert!(state.relax(0), "one set left");
        assert!(!state.seams.on_seam[0] && !state.relax(0));
        // With seams locked an anchor stays one, whatever its corners.
        let locked = SimplifyOptions { lock_seams: true, ..SimplifyOptions::default() };
        let (mut state, _) = State::new(&mesh, &locked);
        state.carry_attributes(&mesh);
        centre_takes_values(&mut state, &[4, 5], 2);
        assert!(!state.relax(0));
    }
}
