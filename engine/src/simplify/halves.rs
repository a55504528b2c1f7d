//! A large mesh simplified in two halves side by side, then as a whole
//! ([`SimplifyOptions::halves`]).
//!
//! The faces are cut in two at the median of their centroids along the bounding box's longest
//! side. A vertex with faces on both sides is on the cut; it and every vertex that shares a face
//! with one form the band, which the first stage leaves alone ([`VertexKind::Locked`]: a band
//! vertex neither moves, goes nor takes in a neighbour). Each half is then simplified apart, on a
//! thread of its own where the pool has two. Off the band a half shows a collapse everything the
//! whole mesh would: the faces of both endpoints and of every neighbour whose fan a rule reads (a
//! face across a moved face's far edge has a band vertex at worst, and no vertex off the band has
//! a face on the other side), and its vertices' quadrics sum the same faces in the same order. So
//! a collapse has the same key and the same verdict in its half as in a run over the whole mesh;
//! what differs is that the band's collapses wait for the second stage, and their neighbours meet
//! other neighbours meanwhile, a difference that spreads as the surface coarsens (how much, and
//! at what error, in docs/benchmarks.md). Each half stops at [`FIRST_STAGE_TARGET`] times the run's target
//! (besides the band's faces): the whole run leaves at most the target on either side, so the
//! first stage never goes further than it would. The fan-distance term starts in each half once
//! the share `FAN_TERM_FROM` of the half's faces is gone. The second stage is one run over what is left, to the
//! target: the quadrics, normals and classes of the vertices off the cut carried over from their
//! half (the faces round a cut vertex never changed, so its quadric is made again from them
//! exactly), the term measured once that share of the whole input's faces is gone.
//!
//! The result is the same on any number of threads (the cut depends on the mesh alone), and the
//! progressive mesh is valid and restores the input exactly (the halves' collapses interleaved by
//! their error, then the second stage's); but its levels are not the meshes straight runs to their
//! face counts give, as they are with `halves` off (each run stops its halves at twice its own
//! target).

use glam::DVec3;

use super::kernel::State;
use super::options::{Metric, Outcome, SimplifyOptions};
use super::run::{self, Run};
use super::vertex::NONE;
use super::vertex::VertexKind;
use crate::error::MeshError;
use crate::mesh::{DistanceUnits, Mesh};
use crate::pm::{CollapseRecord, NO_VERTEX, ProgressiveMesh};

/// The fewest faces a mesh needs for its run to go in halves: below it the halves' setup and the
/// second stage cost more than the first stage saves on two threads.
pub const HALVES_FROM_FACES: usize = 1 << 16;

/// Each half stops at this many times the whole run's target (besides the band's faces), so that
/// the second stage has room to lay the band's faces out with their neighbours'. Chosen over once
/// and four times by the error against one sequence on the shared and corpus meshes large enough
/// for halves (docs/benchmarks.md).
const FIRST_STAGE_TARGET: usize = 2;

/// A run goes in halves only to at most one `HALVES_TO_SHARE`-th of its faces.
pub const HALVES_TO_SHARE: usize = 8;

/// Whether a run of `prepared` to `target` faces goes in halves: large enough, to an eighth of
/// its faces or fewer (each half then does at least half of its collapses in the first stage),
/// with the quadric costs alone (not Melax, the guard, part pruning or an error limit) and without
/// per-corner attributes.
pub(super) fn applies(prepared: &Mesh, options: &SimplifyOptions, target: usize) -> bool {
    let faces = prepared.face_count();
    options.halves
        && faces >= HALVES_FROM_FACES
        && HALVES_TO_SHARE * target <= faces
        && options.metric != Metric::Melax
        && options.guard == 0.0
        && !options.prune
        && options.max_error.is_none()
        && prepared.corners.is_empty()
}

/// One half: its faces (numbers in the whole mesh, rising), its vertices (likewise) and which of
/// them are on the band.
struct Half {
    faces: Vec<u32>,
    vertices: Vec<u32>,
    mesh: Mesh,
    band: Vec<bool>,
}

/// The two halves of `mesh` and, per vertex of it, whether it is on the cut.
fn cut(mesh: &Mesh) -> ([Half; 2], Vec<bool>) {
    let bounds = mesh.bounds().expect("has faces");
    let extent = DVec3::from(bounds.max) - DVec3::from(bounds.min);
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    let n = mesh.face_count();
    // Three times the centroid's coordinate, and the face's number to break ties.
    let keys: Vec<f64> =
        mesh.triangles.iter().map(|t| t.iter().map(|&v| mesh.positions[v as usize][axis] as f64).sum()).collect();
    let order = |f: usize, g: usize| keys[f].total_cmp(&keys[g]).then(f.cmp(&g));
    let mut faces: Vec<usize> = (0..n).collect();
    let middle = n / 2;
    let pivot = *faces.select_nth_unstable_by(middle, |&f, &g| order(f, g)).1;
    drop(faces);
    let side: Vec<u8> = (0..n).map(|f| (order(f, pivot) != std::cmp::Ordering::Less) as u8).collect();
    let mut sides = vec![0u8; mesh.vertex_count()];
    for (t, &s) in mesh.triangles.iter().zip(&side) {
        t.iter().for_each(|&v| sides[v as usize] |= 1 << s);
    }
    let on_cut: Vec<bool> = sides.iter().map(|&s| s == 3).collect();
    let mut band = on_cut.clone();
    for t in &mesh.triangles {
        if t.iter().any(|&v| on_cut[v as usize]) {
            t.iter().for_each(|&v| band[v as usize] = true);
        }
    }
    let half = |s: u8| {
        let faces: Vec<u32> = (0..n as u32).filter(|&f| side[f as usize] == s).collect();
        let vertices: Vec<u32> =
            (0..mesh.vertex_count() as u32).filter(|&v| sides[v as usize] & (1 << s) != 0).collect();
        let mut local = vec![NONE; mesh.vertex_count()];
        for (i, &v) in vertices.iter().enumerate() {
            local[v as usize] = i as u32;
        }
        let sub = Mesh {
            positions: vertices.iter().map(|&v| mesh.positions[v as usize]).collect(),
            triangles: faces.iter().map(|&f| mesh.triangles[f as usize].map(|v| local[v as usize])).collect(),
            corners: Default::default(),
        };
        let band = vertices.iter().map(|&v| band[v as usize]).collect();
        Half { faces, vertices, mesh: sub, band }
    };
    ([half(0), half(1)], on_cut)
}

/// A half's state with its band locked, and its edges off the band; `None` where it has faces
/// stacked on another (`super::sheets`), which the run over the whole mesh sets aside instead.
fn half_state<'o>(half: &Half, options: &'o SimplifyOptions) -> Option<(State<'o>, Vec<[u32; 2]>)> {
    let (mut state, edges) = State::with_tracking(&half.mesh, options, false);
    if !state.stacked_faces(&half.mesh).is_empty() {
        return None;
    }
    for (vertex, &band) in state.vertices.iter_mut().zip(&half.band) {
        if band {
            vertex.kind = VertexKind::Locked;
        }
    }
    let edges = edges.into_iter().filter(|e| !(half.band[e[0] as usize] || half.band[e[1] as usize])).collect();
    Some((state, edges))
}

/// The first stage of a half: its state (from [`half_state`]) simplified.
fn first_stage(
    half: &Half,
    state: &mut State<'_>,
    edges: Vec<[u32; 2]>,
    units: &DistanceUnits,
    target: usize,
) -> Result<Run, MeshError> {
    let heap = run::initial_queue(state, edges, half.mesh.face_count());
    // The faces with every corner on the band stay as they are; the others stop at twice the
    // target.
    let faces = half.mesh.face_count();
    let fixed = half.mesh.triangles.iter().filter(|t| t.iter().all(|&v| half.band[v as usize])).count();
    let run = run::run(state, heap, None, units, faces, (FIRST_STAGE_TARGET * target + fixed).min(faces))?;
    state.rebuild_triangles(&half.mesh, &run.log);
    Ok(run)
}

/// A record of a half's (or the second stage's) run in the whole mesh's numbers.
fn renumber(r: &CollapseRecord, vertex: &[u32], face: &[u32]) -> CollapseRecord {
    let v = |x: u32| if x == NO_VERTEX { NO_VERTEX } else { vertex[x as usize] };
    let f = |x: u32| if x == NONE { NONE } else { face[x as usize] };
    CollapseRecord {
        survivor: v(r.survivor),
        removed: v(r.removed),
        left: v(r.left),
        right: v(r.right),
        hole: v(r.hole),
        left_face: f(r.left_face),
        right_face: f(r.right_face),
        ..*r
    }
}

/// `prepared` simplified to `target` faces in halves, then as a whole; `None` where a half or the
/// rest has stacked faces (the caller then runs over the whole mesh).
pub(super) fn simplify(
    prepared: &Mesh,
    input_vertex: &[u32],
    options: &SimplifyOptions,
    units: &DistanceUnits,
    target: usize,
) -> Result<Option<Outcome>, MeshError> {
    let ([mut h0, mut h1], on_cut) = cut(prepared);
    let faces = prepared.face_count();
    let (s0, s1) = crate::parallel::join(faces, || half_state(&h0, options), || half_state(&h1, options));
    let (Some((mut st0, e0)), Some((mut st1, e1))) = (s0, s1) else { return Ok(None) };
    let (run0, run1) = crate::parallel::join(
        faces,
        || first_stage(&h0, &mut st0, e0, units, target),
        || first_stage(&h1, &mut st1, e1, units, target),
    );
    let (run0, run1) = (run0?, run1?);
    // (The halves' meshes and, once the rest's state is made, their states are done with: their
    // memory goes back before the second stage.)
    (h0.mesh, h1.mesh) = (Mesh::default(), Mesh::default());
    let n = prepared.vertex_count();
    let (rest, whole_vertex, rest_vertex, whole_face, (mut state, edges)) =
        rest_of(n, [(&h0, &st0), (&h1, &st1)], &on_cut, options);
    drop((st0, st1));
    if !state.stacked_faces(&rest).is_empty() {
        return Ok(None);
    }
    state.terms.term_base = prepared.face_count();
    let heap = run::initial_queue(&state, edges, rest.face_count());
    let run2 = run::run(&mut state, heap, None, units, rest.face_count(), target)?;
    state.rebuild_triangles(&rest, &run2.log);
    let mesh = state.output_mesh();
    let first_error = run0.max_collapse_error.max(run1.max_collapse_error);
    let mut refused = run0.refused;
    refused.add(&run1.refused);
    refused.add(&run2.refused);
    let collapses = run0.log.len() + run1.log.len() + run2.log.len();
    let holes_closed =
        [&run0.log, &run1.log, &run2.log].iter().flat_map(|l| l.iter()).filter(|r| r.hole != NO_VERTEX).count();
    let progressive = options.record_progressive.then(|| {
        let log = merged_log([(&run0, &h0), (&run1, &h1)], &run2, (&whole_vertex, &whole_face), first_error);
        let triangles: Vec<[u32; 3]> =
            state.topo.triangles.iter().map(|t| t.map(|v| whole_vertex[v as usize])).collect();
        ProgressiveMesh::from_log(
            prepared,
            input_vertex,
            |v| state.vertices[rest_vertex[v as usize] as usize].position,
            &triangles,
            &state.topo.face_alive,
            log,
            None,
        )
    });
    Ok(Some(Outcome {
        mesh,
        progressive,
        collapses,
        holes_closed,
        stop_reason: run2.stop_reason,
        max_collapse_error: first_error.max(run2.max_collapse_error),
        refused,
        frozen_vertices: state.frozen_vertices(),
        parts_removed: 0,
        dropped_duplicate_faces: 0,
        back_faces: 0,
        halves: true,
        distance_term: state.terms.fan_term,
    }))
}

/// What the two halves left, as one mesh for the second stage: their live vertices and faces in
/// the whole mesh's order (`n` vertices), with the numbers of its vertices in the whole mesh, of
/// the whole mesh's vertices in it, and of its faces in the whole mesh; and its state, in which a
/// vertex off the cut (`on_cut`) keeps its class, quadric and normal from its half.
#[allow(clippy::type_complexity)]
fn rest_of<'o>(
    n: usize,
    halves: [(&Half, &State); 2],
    on_cut: &[bool],
    options: &'o SimplifyOptions,
) -> (Mesh, Vec<u32>, Vec<u32>, Vec<u32>, (State<'o>, Vec<[u32; 2]>)) {
    // What is left: the live vertices and faces of both halves, in the whole mesh's order.
    let mut place = vec![(u8::MAX, NONE); n]; // (half, its number there) of each vertex
    for (s, (half, state)) in halves.iter().enumerate() {
        for (i, &v) in half.vertices.iter().enumerate() {
            if state.topo.vertex_alive[i] && !state.topo.fans[i].is_empty() && place[v as usize].0 == u8::MAX {
                place[v as usize] = (s as u8, i as u32);
            }
        }
    }
    let mut rest_vertex = vec![NONE; n];
    let mut whole_vertex = Vec::new();
    for v in 0..n {
        if place[v].0 != u8::MAX {
            rest_vertex[v] = whole_vertex.len() as u32;
            whole_vertex.push(v as u32);
        }
    }
    let block = |v: u32| {
        let (s, i) = place[v as usize];
        &halves[s as usize].1.vertices[i as usize]
    };
    let mut faces: Vec<(u32, [u32; 3])> = Vec::new();
    for (half, state) in halves {
        faces.extend(
            (0..half.faces.len())
                .filter(|&f| state.topo.face_alive[f])
                .map(|f| (half.faces[f], state.topo.triangles[f].map(|v| half.vertices[v as usize]))),
        );
    }
    faces.sort_unstable_by_key(|f| f.0);
    let rest = Mesh {
        positions: whole_vertex.iter().map(|&v| block(v).position).collect(),
        triangles: faces.iter().map(|(_, t)| t.map(|v| rest_vertex[v as usize])).collect(),
        corners: Default::default(),
    };
    let whole_face: Vec<u32> = faces.iter().map(|f| f.0).collect();
    drop(faces);
    // The second stage: off the cut, a vertex keeps its class, quadric and normal from its half.
    let carry = |i: usize, vertex: &mut super::vertex::VertexData| {
        let v = whole_vertex[i];
        if !on_cut[v as usize] {
            let from = block(v);
            if from.kind != VertexKind::Locked {
                vertex.kind = from.kind;
            }
            vertex.quadric = from.quadric;
            vertex.normal = from.normal;
        }
    };
    let state = State::with_carried(&rest, options, false, Some(carry));
    (rest, whole_vertex, rest_vertex, whole_face, state)
}

/// The halves' records interleaved by their error (rising within each), then the second stage's
/// (in the numbers of the rest: `whole`, its vertices' and faces' numbers in the whole mesh), all
/// in the whole mesh's numbers; the second stage's errors no lower than the halves' largest.
fn merged_log(
    halves: [(&Run, &Half); 2],
    second: &Run,
    (whole_vertex, whole_face): (&[u32], &[u32]),
    first_error: f64,
) -> Vec<CollapseRecord> {
    let [(run0, h0), (run1, h1)] = halves;
    let mut log = Vec::with_capacity(run0.log.len() + run1.log.len() + second.log.len());
    let (mut i, mut j) = (0, 0);
    let (l0, l1) = (&run0.log, &run1.log);
    while i < l0.len() || j < l1.len() {
        if j == l1.len() || (i < l0.len() && l0[i].error <= l1[j].error) {
            log.push(renumber(&l0[i], &h0.vertices, &h0.faces));
            i += 1;
        } else {
            log.push(renumber(&l1[j], &h1.vertices, &h1.faces));
            j += 1;
        }
    }
    log.extend(second.log.iter().map(|r| {
        let r = renumber(r, whole_vertex, whole_face);
        CollapseRecord { error: r.error.max(first_error as f32), ..r }
    }));
    log
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::procedural;

    #[test]
    fn the_cut_splits_the_faces_evenly_and_the_band_holds_every_face_at_the_cut() {
        let mesh = procedural::bumpy_blob(40, 60, 1);
        let ([h0, h1], on_cut) = cut(&mesh);
        assert_eq!(h0.faces.len() + h1.faces.len(), mesh.face_count());
        assert!(h0.faces.len().abs_diff(h1.faces.len()) <= 1);
        let mut side = vec![2u8; mesh.face_count()];
        for (s, half) in [&h0, &h1].into_iter().enumerate() {
            assert!(half.faces.windows(2).all(|w| w[0] < w[1]) && half.vertices.windows(2).all(|w| w[0] < w[1]));
            for (i, &f) in half.faces.iter().enumerate() {
                side[f as usize] = s as u8;
                // The half's face is the mesh's, renumbered.
                assert_eq!(half.mesh.triangles[i].map(|v| half.vertices[v as usize]), mesh.triangles[f as usize]);
            }
        }
        assert!(side.iter().all(|&s| s < 2));
        let cut_count = on_cut.iter().filter(|&&c| c).count();
        assert!(cut_count > 0 && cut_count < mesh.vertex_count() / 4, "{cut_count} vertices on the cut");
        for half in [&h0, &h1] {
            let band: Vec<bool> = {
                let mut b = vec![false; mesh.vertex_count()];
                half.vertices.iter().zip(&half.band).for_each(|(&v, &x)| b[v as usize] = x);
                b
            };
            for (v, &c) in on_cut.iter().enumerate() {
                assert!(!c || band[v], "a cut vertex off the band");
            }
            // A face with a cut vertex has all its corners on the band: a vertex off the band has
            // no face on the other side and no neighbour with one.
            for &f in &half.faces {
                let t = mesh.triangles[f as usize];
                if t.iter().any(|&v| on_cut[v as usize]) {
                    assert!(t.iter().all(|&v| band[v as usize]));
                }
            }
        }
        // A vertex in both halves is exactly a cut vertex.
        let mut seen = vec![0u8; mesh.vertex_count()];
        for (s, half) in [&h0, &h1].into_iter().enumerate() {
            half.vertices.iter().for_each(|&v| seen[v as usize] |= 1 << s);
        }
        assert!(seen.iter().zip(&on_cut).all(|(&s, &c)| (s == 3) == c));
    }
}
