//! Faces stacked on the same three vertices: exact copies of a face, and back-to-back twins (a face
//! and its reverse, as a double-sided sheet is often modelled). Either gives each edge of the face
//! more than two faces, which freezes its vertices (rule 1): a double-sided mesh did not simplify
//! at all. A run sets them aside first: a copy is dropped; a back is simplified with the face it
//! backs, as one sheet, and each output face whose input face had a back is written again,
//! reversed, beside it. Only a face whose corners carry the same values as the face it stacks on
//! (vertex by vertex) is set aside, but for a back's normals, which may point the other way (the
//! back lit from behind): its output copy then has the front's normals turned round. The others
//! stay, and freeze their vertices as before.

use crate::mesh::Mesh;

use super::topology::Topology;
use super::vertex::NONE;

/// The back set aside for a face of the one-sided mesh.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(super) enum Back {
    #[default]
    None,
    /// With the face's own values.
    Same,
    /// With its values but for normals pointing the other way.
    Flipped,
}

/// A face stacked on an earlier one ([`State::stacked_faces`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct StackedFace {
    pub(super) face: u32,
    /// The face it stacks on.
    pub(super) on: u32,
    /// `None` for a copy (same way round), else the kind of back.
    pub(super) back: Option<Back>,
}

/// What a run set aside of the faces stacked on another ([module docs](self)).
#[derive(Debug, Default)]
pub(super) struct Stacked {
    /// Faces that copy an earlier face, dropped.
    pub(super) copies: usize,
    /// Faces that back an earlier face, simplified with it and written back reversed.
    pub(super) twins: usize,
    /// Per face of the one-sided mesh, its back (empty when none was set aside).
    pub(super) backs: Vec<Back>,
}

/// The faces face `f` stands for in the output: itself and its back, if one was set aside for
/// it (none for `NONE`).
#[inline]
pub(super) fn output_faces(backs: &[Back], f: u32) -> usize {
    if f == NONE { 0 } else { 1 + backs.get(f as usize).is_some_and(|&b| b != Back::None) as usize }
}

/// The faces of `mesh` (the state's) stacked on an earlier face with its values. Such faces
/// freeze their vertices, so only the fans of the vertices the scan found frozen are looked
/// at: a mesh without them costs nothing.
pub(super) fn stacked_faces(topo: &Topology, frozen_at_start: &[u32], mesh: &Mesh) -> Vec<StackedFace> {
    let mut found = Vec::new();
    let mut at = Vec::new();
    for &v in frozen_at_start {
        // Each face once: at its lowest vertex, by its other two (unordered), then by number.
        at.clear();
        at.extend(
            topo.fans[v as usize]
                .iter()
                .filter(|c| v < c.next && v < c.prev)
                .map(|c| (c.next.min(c.prev), c.next.max(c.prev), c.face, c.next)),
        );
        at.sort_unstable();
        for run in at.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1)).filter(|run| run.len() > 1) {
            let (_, _, on, on_next) = run[0];
            // Whether the first back found has its normals turned round.
            let mut first_back = None;
            for &(_, _, face, next) in &run[1..] {
                let Some(flipped) = values_of(mesh, on, face) else { continue };
                let back = match (next != on_next, first_back) {
                    // The same way round with its normals turned: not a copy.
                    (false, _) if flipped => continue,
                    (false, _) => None,
                    (true, None) => {
                        first_back = Some(flipped);
                        Some(if flipped { Back::Flipped } else { Back::Same })
                    }
                    // A second back: a copy of the first, unless its normals differ from it.
                    (true, Some(first)) if first == flipped => None,
                    (true, Some(_)) => continue,
                };
                found.push(StackedFace { face, on, back });
            }
        }
    }
    found
}

/// How face `g`'s corners carry face `f`'s values, vertex by vertex (the two on the same three
/// vertices): `Some(false)` the same values, `Some(true)` the same but for normals pointing the
/// other way (all three), `None` other values.
fn values_of(mesh: &Mesh, f: u32, g: u32) -> Option<bool> {
    let c = &mesh.corners;
    if c.is_empty() {
        return Some(false);
    }
    let (tf, tg) = (mesh.triangles[f as usize], mesh.triangles[g as usize]);
    let pairs: [(usize, usize); 3] = std::array::from_fn(|k| {
        let j = tg.iter().position(|&x| x == tf[k]).expect("the same three vertices");
        (3 * f as usize + k, 3 * g as usize + j)
    });
    if pairs.iter().all(|&(a, b)| c.same(a, b)) {
        return Some(false);
    }
    let normals = c.normals()?;
    let bits = |n: [f32; 3]| n.map(f32::to_bits);
    let turned = |a: usize, b: usize| bits(normals[a].map(|x| -x)) == bits(normals[b]);
    pairs.iter().all(|&(a, b)| turned(a, b) && c.same_but_normals(a, b)).then_some(true)
}

/// `mesh` without the `stacked` faces ([`State::stacked_faces`]), and what was set aside. The
/// vertices stay as they are (each is on the face its stacked faces rest on).
pub(super) fn one_sided(mesh: &Mesh, stacked: &[StackedFace]) -> (Mesh, Stacked) {
    let mut aside = vec![false; mesh.face_count()];
    let mut backs = vec![Back::None; mesh.face_count()];
    let mut set = Stacked::default();
    for s in stacked {
        aside[s.face as usize] = true;
        match s.back {
            Some(back) => {
                backs[s.on as usize] = back;
                set.twins += 1;
            }
            None => set.copies += 1,
        }
    }
    let kept: Vec<usize> = (0..mesh.face_count()).filter(|&f| !aside[f]).collect();
    set.backs = kept.iter().map(|&f| backs[f]).collect();
    let triangles = kept.iter().map(|&f| mesh.triangles[f]).collect();
    let corners = if mesh.corners.is_empty() {
        Default::default()
    } else {
        mesh.corners.pick(kept.iter().flat_map(|&f| [3 * f, 3 * f + 1, 3 * f + 2]))
    };
    (Mesh { positions: mesh.positions.clone(), triangles, corners }, set)
}

/// `out` (the one-sided result) with each face whose input face had a back written again,
/// reversed (and with its normals turned round where the back's were), after the others; `live`
/// gives, for each face of `out` in order, its face of the one-sided mesh (`backs` empty: nothing
/// was set aside).
pub(super) fn with_backs(mut out: Mesh, live: impl Iterator<Item = usize>, backs: &[Back]) -> Mesh {
    if backs.is_empty() {
        return out;
    }
    let backed: Vec<(usize, Back)> =
        live.enumerate().filter(|&(_, f)| backs[f] != Back::None).map(|(i, f)| (i, backs[f])).collect();
    if backed.is_empty() {
        return out;
    }
    let n = out.face_count();
    for &(i, _) in &backed {
        let [a, b, c] = out.triangles[i];
        out.triangles.push([a, c, b]);
    }
    if !out.corners.is_empty() {
        let reversed = backed.iter().flat_map(|&(i, _)| [3 * i, 3 * i + 2, 3 * i + 1]);
        out.corners = out.corners.pick((0..3 * n).chain(reversed));
        if let Some(normals) = out.corners.normals_mut() {
            for (k, _) in backed.iter().enumerate().filter(|(_, (_, back))| *back == Back::Flipped) {
                for n in &mut normals[3 * (n + k)..3 * (n + k + 1)] {
                    *n = n.map(|x| -x);
                }
            }
        }
    }
    debug_assert!(out.check().is_ok());
    out
}

#[cfg(test)]
mod tests {
    use super::super::{SimplifyOptions, StopReason, simplify};
    use crate::mesh::Mesh;
    use crate::procedural;

    fn to(faces: usize) -> SimplifyOptions {
        SimplifyOptions {
            target_faces: Some(faces),
            target_ratio: None,
            record_progressive: true,
            ..Default::default()
        }
    }

    fn reversed(t: [u32; 3]) -> [u32; 3] {
        [t[0], t[2], t[1]]
    }

    /// A sheet modelled double-sided (each face and its reverse) freezes every vertex as it is;
    /// set aside, its back faces follow the front: the front simplifies as the sheet alone does,
    /// and each of its faces comes out with its reverse. The progressive mesh is the front's.
    #[test]
    fn a_double_sided_sheet_simplifies_as_its_front_and_keeps_both_sides() {
        let front = procedural::terrain(24, 3);
        let n = front.face_count();
        let mut both = front.clone();
        both.triangles.extend(front.triangles.iter().map(|&t| reversed(t)));
        let alone = simplify(&front, &to(n / 10)).unwrap();
        let out = simplify(&both, &to(2 * (n / 10))).unwrap();
        assert_eq!(out.stats.stop_reason, StopReason::TargetReached);
        assert_eq!((out.stats.back_faces, out.stats.dropped_duplicate_faces), (n, 0));
        assert_eq!(out.stats.faces_in, 2 * n);
        let k = alone.mesh.face_count();
        assert_eq!(out.mesh.face_count(), 2 * k);
        assert_eq!(out.mesh.positions, alone.mesh.positions);
        assert_eq!(out.mesh.triangles[..k], alone.mesh.triangles[..]);
        let backs: Vec<[u32; 3]> = alone.mesh.triangles.iter().map(|&t| reversed(t)).collect();
        assert_eq!(out.mesh.triangles[k..], backs[..]);
        // (Levels number their vertices in the order the splits bring them: compared by position.)
        let faces = |m: &Mesh| {
            let mut f: Vec<[[u32; 3]; 3]> =
                m.triangles.iter().map(|t| t.map(|v| m.positions[v as usize].map(f32::to_bits))).collect();
            for t in &mut f {
                let first = (0..3).min_by_key(|&k| t[k]).expect("three corners");
                t.rotate_left(first);
            }
            f.sort_unstable();
            f
        };
        let pm = out.progressive.unwrap();
        assert_eq!(faces(&pm.at_level(pm.levels())), faces(&front));
        // What the set-aside avoids: the two sides together freeze every vertex but a corner or
        // two of the grid (whose edges all have the two faces, one each way, of a manifold edge).
        let defaults = to(0);
        let (state, _) = super::super::State::new(&both, &defaults);
        let frozen = state.frozen_at_start.len();
        assert!(frozen + 4 >= both.vertex_count(), "{frozen} frozen");
    }

    /// A back whose normals point the other way (the back lit from behind, as exporters write a
    /// double-sided sheet with normals) is set aside too: its output copy has the front's normals
    /// turned round, corner by corner.
    #[test]
    fn a_back_with_normals_turned_round_comes_out_with_them_turned_round() {
        let mut front = procedural::terrain(16, 7);
        let n = front.face_count();
        let normals: Vec<[f32; 3]> = (0..n)
            .flat_map(|f| {
                let u = front.face_area_vector(f).normalize_or_zero();
                [[u.x as f32, u.y as f32, u.z as f32]; 3]
            })
            .collect();
        front.corners.set_normals(Some(normals.clone()));
        let mut both = front.clone();
        both.triangles.extend(front.triangles.iter().map(|&t| reversed(t)));
        // The back's corners in its own order (a, c, b): the front's normals there, turned round.
        let turned = |k: usize| normals[k].map(|x| -x);
        let back_normals = (0..n).flat_map(|f| [turned(3 * f), turned(3 * f + 2), turned(3 * f + 1)]);
        both.corners.set_normals(Some(normals.iter().copied().chain(back_normals).collect()));
        let alone = simplify(&front, &to(n / 8)).unwrap();
        let out = simplify(&both, &to(2 * (n / 8))).unwrap();
        assert_eq!(out.stats.back_faces, n, "{:?}", out.stats);
        let k = alone.mesh.face_count();
        assert_eq!(out.mesh.face_count(), 2 * k);
        assert_eq!(out.mesh.triangles[..k], alone.mesh.triangles[..]);
        let (got, kept) = (out.mesh.corners.normals().unwrap(), alone.mesh.corners.normals().unwrap());
        assert_eq!(got[..3 * k], kept[..]);
        for i in 0..k {
            let back = [kept[3 * i], kept[3 * i + 2], kept[3 * i + 1]].map(|n| n.map(|x| -x));
            assert_eq!(got[3 * (k + i)..3 * (k + i + 1)], back, "back of face {i}");
        }
    }

    /// Exact copies go (the result is the one of the mesh without them); faces on the same three
    /// vertices with other values stay, and freeze their vertices as before.
    #[test]
    fn copies_are_dropped_and_stacked_faces_with_other_values_stay() {
        let sphere = procedural::icosphere(3);
        let mut copied = sphere.clone();
        copied.triangles.extend_from_slice(&sphere.triangles[..10]);
        let options = to(sphere.face_count() / 10);
        let out = simplify(&copied, &options).unwrap();
        assert_eq!((out.stats.dropped_duplicate_faces, out.stats.back_faces), (10, 0));
        assert_eq!(out.mesh, simplify(&sphere, &options).unwrap().mesh);
        // The same copies with texture coordinates of their own.
        let corners = copied.face_count() * 3;
        let uvs = (0..corners).map(|k| if k < sphere.face_count() * 3 { [0.0, 0.0] } else { [1.0, 1.0] }).collect();
        let mut distinct: Mesh = copied.clone();
        distinct.corners.set_uvs(Some(uvs));
        let out = simplify(&distinct, &options).unwrap();
        assert_eq!(out.stats.dropped_duplicate_faces, 0);
        assert!(out.stats.frozen_vertices > 0, "{:?}", out.stats);
    }
}
