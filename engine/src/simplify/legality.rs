//! Whether a collapse keeps the surface valid, rule by rule in the order of the module doc
//! (`super`), each refusal named ([`Refusal`]); a collapse that passes comes back as a [`Legal`]
//! token, the only thing [`State::collapse`] accepts.

use glam::DVec3;

use super::candidate::{Candidate, Legal};
use super::kernel::State;
use super::options::{BoundaryMode, Refusal};
use super::vertex::VertexKind;
use super::vertex::{FOLD_DOT, NONE, to_f64, triangle_quality};
use crate::fan::Corner;

/// Smallest `4√3·area / Σ edge²` (1 for an equilateral triangle) a collapse may create.
pub const MIN_TRIANGLE_QUALITY: f64 = 1e-3;

/// Whether two faces of a new fan (far edge, unit normal) that share a vertex other than the
/// merged one turn back onto each other: every pair looked at, the reference for the one-pass
/// check in [`State::is_legal`].
fn folds_pairwise(fan: &[([u32; 2], DVec3)]) -> bool {
    (0..fan.len()).any(|i| {
        (i + 1..fan.len()).any(|j| {
            let ([a, b], ni) = fan[i];
            let ([c, d], nj) = fan[j];
            (a == c || a == d || b == c || b == d) && ni.dot(nj) < FOLD_DOT
        })
    })
}

impl State<'_> {
    /// Rules 3–7 of the module doc for a candidate, 7 first: the [`Legal`] token that
    /// [`State::collapse`] takes, or the first rule that refuses it.
    pub(crate) fn is_legal(&mut self, c: &Candidate) -> Result<Legal, Refusal> {
        self.scratch.check_id = self.scratch.check_id.wrapping_add(1);
        let (a, b) = (c.survivor, c.removed);
        self.prefetch_ring(a, b);
        // Rule 3: the edge has one or two faces.
        let (shared, shared_count) = self.edge_corners(a, b);
        if shared_count == 0 || shared_count > 2 {
            return Err(Refusal::Link);
        }
        // Rule 7, with per-corner attributes only: no values carried across a seam. Checked before
        // the rest of rule 3, which reads both fans in full: it is cheaper, and on textured meshes
        // it is the rule that refuses most.
        if !self.seams.corner_source.is_empty() {
            let dead = [shared[0].face, if shared_count == 2 { shared[1].face } else { NONE }];
            let sides = self.seam_sides(a, b, &dead[..shared_count]).ok_or(Refusal::Seam)?;
            if !self.texture_keeps_orientation(b, &dead, sides) {
                return Err(Refusal::UvFlip);
            }
        }
        let opposite = [shared[0].other(b), if shared_count == 2 { shared[1].other(b) } else { NONE }];
        let hole = self.link_condition(a, b, opposite, shared[0], shared_count)?;
        // Rule 1 for a frozen survivor (non-manifold or inconsistently oriented around it): its
        // edges to the opposite vertices each have exactly one face besides the collapsing one,
        // which crosses the edge the other way, so that the faces b brings attach to one sheet,
        // the vertex split that undoes the collapse walks them unambiguously, and no edge is left
        // without a face (a triangle hanging from the vertex by a corner would vanish, splitting
        // the boundary it joined).
        let frozen = self.vertices[a as usize].kind == VertexKind::Frozen;
        if frozen && !opposite.iter().all(|&v| v == NONE || self.attaches_cleanly(a, b, v)) {
            return Err(Refusal::Link);
        }
        // Rule 3, the merged vertex keeps enough faces.
        let remaining = self.topo.fans[a as usize].len() + self.topo.fans[b as usize].len() - 2 * shared_count;
        let interior = hole != NONE || (self.is_interior(a) && self.is_interior(b));
        if remaining < if interior { 3 } else { 1 } {
            return Err(Refusal::TooFewFaces);
        }
        // Rules 4–6 on each surviving face: normal change, needle, fold onto the face across.
        let p = to_f64(c.position);
        let mut fan = std::mem::take(&mut self.scratch.fan_scratch);
        fan.clear();
        for (v, other) in [(a, b), (b, a)] {
            let pv = self.point(v);
            for corner in &self.topo.fans[v as usize] {
                if corner.touches(other) {
                    continue;
                }
                let (x, y) = (corner.next, corner.prev);
                let (px, py) = (self.point(x), self.point(y));
                let n_old = (px - pv).cross(py - pv);
                let n_new = (px - p).cross(py - p);
                let (lo, ln) = (n_old.length(), n_new.length());
                // (A zero-area new face passes this test and fails the next.)
                if lo > 0.0 && n_old.dot(n_new) < self.config.cos_max_normal_change * lo * ln {
                    self.scratch.fan_scratch = fan;
                    return Err(Refusal::NormalChange);
                }
                if ln == 0.0 || triangle_quality(ln, p, px, py) < MIN_TRIANGLE_QUALITY {
                    self.scratch.fan_scratch = fan;
                    return Err(Refusal::Needle);
                }
                let n_new = n_new / ln;
                // The face across the far edge (x, y) keeps its normal; the moved face must not
                // fold onto it. Looked at only when the cones of x and y cannot rule that out.
                let (vx, vy) = (&self.vertices[x as usize], &self.vertices[y as usize]);
                let ruled_out = vx.cone.excludes_fold(vx.normal, n_new) || vy.cone.excludes_fold(vy.normal, n_new);
                debug_assert!(!ruled_out || !self.folds_across(corner.face, a, b, [x, y], [px, py], n_new));
                if !ruled_out && self.folds_across(corner.face, a, b, [x, y], [px, py], n_new) {
                    self.scratch.fan_scratch = fan;
                    return Err(Refusal::Fold);
                }
                fan.push(([x, y], n_new));
            }
        }
        let folded = new_fan_folds(&mut self.scratch.spoke, &fan, frozen);
        self.scratch.fan_scratch = fan;
        if folded {
            return Err(Refusal::Fold);
        }
        Ok(Legal { candidate: *c, check: self.scratch.check_id, hole })
    }

    /// Rule 3, link condition: the common neighbours of the edge's ends are exactly the
    /// `opposite` vertices of its faces (`first` one of them, `shared_count` in all), or those and
    /// the third corner of a triangular hole that the collapse closes: that corner, or [`NONE`].
    #[inline]
    fn link_condition(
        &mut self,
        a: u32,
        b: u32,
        opposite: [u32; 2],
        first: Corner,
        shared_count: usize,
    ) -> Result<u32, Refusal> {
        let stamp = self.next_stamp();
        for corner in &self.topo.fans[a as usize] {
            self.scratch.mark[corner.next as usize] = stamp;
            self.scratch.mark[corner.prev as usize] = stamp;
        }
        // Counted without a branch on the data (whether a neighbour of b is one of a's is as good
        // as random): each common neighbour once, and those not opposite the edge (the last one).
        let mut common = 0;
        let mut strays = 0;
        let mut stray = NONE;
        for corner in &self.topo.fans[b as usize] {
            for v in [corner.next, corner.prev] {
                let mark = &mut self.scratch.mark[v as usize];
                let hit = (v != a) & (*mark == stamp);
                *mark = if hit { stamp.wrapping_sub(1) } else { *mark }; // count each neighbour once
                let off_edge = hit & (v != opposite[0]) & (v != opposite[1]);
                strays += off_edge as usize;
                stray = if off_edge { v } else { stray };
                common += hit as usize;
            }
        }
        if strays == 0 && common == shared_count {
            Ok(NONE)
        } else if strays == 1 && common == 2 && shared_count == 1 && self.closes_hole(a, b, stray, first) {
            Ok(stray)
        } else {
            Err(Refusal::Link)
        }
    }

    /// Whether edge (a, v) has, besides the face it shares with b, exactly one face, crossing the
    /// edge the other way (a → v in one, v → a in the other).
    fn attaches_cleanly(&self, a: u32, b: u32, v: u32) -> bool {
        let (mut forward, mut back, mut others) = (0, 0, 0);
        for corner in &self.topo.fans[a as usize] {
            forward += (corner.next == v) as u32;
            back += (corner.prev == v) as u32;
            others += (corner.touches(v) && !corner.touches(b)) as u32;
        }
        others == 1 && forward == 1 && back == 1
    }

    /// Whether boundary edge (a, b), whose one face is `edge_face` (a's corner of it), and c, a
    /// common neighbour of a and b off that face, bound a triangular hole that collapsing (a, b)
    /// closes: a, b and c are plain boundary vertices (one open fan each), (a, c) and (b, c) are
    /// boundary edges whose faces run the hole's way round (so that, renamed, they meet across
    /// (a, c) as a manifold edge does), those faces' third corners differ (else the two would
    /// become one face twice: a tetrahedron missing one face), and c keeps three faces or more
    /// once its fan closes. With per-corner attributes, the two faces that come to meet across
    /// (a, c) also agree on the values there (b's corners take a's values in the edge's face):
    /// closing the hole makes no seam that rule 7 did not see.
    fn closes_hole(&self, a: u32, b: u32, c: u32, edge_face: Corner) -> bool {
        let plain = |v: u32| self.vertices[v as usize].kind == VertexKind::Boundary;
        if !(plain(a) && plain(b) && plain(c)) || self.topo.fans[c as usize].len() < 3 {
            return false;
        }
        let only_face = |x: u32| match self.edge_corners(x, c) {
            (corners, 1) => Some(corners[0]),
            _ => None,
        };
        let (Some(ac), Some(bc)) = (only_face(a), only_face(b)) else { return false };
        // With the face of (a, b) running a → b, the hole runs b → a → c: the face on (a, c) runs
        // c → a and the one on (b, c) b → c.
        let runs = if edge_face.next == b { ac.prev == c && bc.next == c } else { ac.next == c && bc.prev == c };
        let values_agree = self.seams.corner_source.is_empty() || {
            let same = |f: u32, g: u32, v: u32| self.same_values(self.source_at(f, v), self.source_at(g, v));
            same(ac.face, edge_face.face, a) && same(ac.face, bc.face, c)
        };
        runs && ac.other(c) != bc.other(c) && values_agree
    }

    /// Whether `v` has a closed fan (an anchor is looked at: its kind does not say).
    fn is_interior(&self, v: u32) -> bool {
        match self.vertices[v as usize].kind {
            VertexKind::Interior => true,
            VertexKind::Boundary | VertexKind::Frozen | VertexKind::Locked => false,
            VertexKind::Anchored => {
                let fan = &self.topo.fans[v as usize];
                fan.iter().all(|c| fan.iter().any(|d| d.prev == c.next))
            }
        }
    }

    /// Whether the moved face `face` (now with unit normal `n_new`, far edge (x, y) at `px`, `py`)
    /// folds onto the face across its far edge, which is not a face of the collapsing edge (a, b).
    pub(super) fn folds_across(
        &self,
        face: u32,
        a: u32,
        b: u32,
        [x, y]: [u32; 2],
        [px, py]: [DVec3; 2],
        n_new: DVec3,
    ) -> bool {
        let across = self.topo.fans[x as usize].iter().find(|d| {
            d.face != face && d.touches(y) && {
                let z = d.other(y);
                z != a && z != b
            }
        });
        across.is_some_and(|d| {
            // One corner of the face across is y, already at hand: only its third is read.
            let (pn, pp) = if d.next == y { (py, self.point(d.prev)) } else { (self.point(d.next), py) };
            let n_across = (pn - px).cross(pp - px).normalize_or_zero();
            n_across.dot(n_new) < FOLD_DOT
        })
    }
}

impl State<'_> {
    /// Looks again at vertex `v` after a collapse took faces from it: whether a rule that held it
    /// because of its sets of values no longer does, in which case its edges are to be ranked
    /// again. Collapses only ever take sets away from a vertex (a removed vertex's corners take
    /// the survivor's values), so what this lifts never comes back.
    ///
    /// - An anchor (three or more sets met at the start) whose faces now carry exactly two sets,
    ///   with the same texture coordinates, is released: an ordinary vertex again (interior or
    ///   boundary, as its fan is closed or not), still on its seam, so it moves along it. Where the
    ///   two sets differ in normals only (a hard edge through the vertex, the texture continuous)
    ///   it moves along that edge as any vertex of the edge does (on an asset whose anchors are
    ///   mostly of that kind, the position error at 10% fell to a third and the texture error to a
    ///   quarter: docs/attributes-report.md). The other anchors stay, as measured: released where
    ///   the two sets differ in texture coordinates, seam vertices slid along the seam and nearly
    ///   doubled the texture error; released where one set is left, the position error rose.
    /// - A seam vertex whose faces now carry one set is off the seam: inside one chart, it collapses
    ///   as the chart's other vertices do.
    ///
    /// Nothing with locked seams, and no anchor with locked borders: those stay whatever their
    /// corners.
    pub(super) fn relax(&mut self, v: u32) -> bool {
        let kind = self.vertices[v as usize].kind;
        let anchor = kind == VertexKind::Anchored && self.config.options.boundary != BoundaryMode::Lock;
        let seam = self.seams.on_seam[v as usize] && matches!(kind, VertexKind::Interior | VertexKind::Boundary);
        if self.config.options.lock_seams || !(anchor || seam) {
            return false;
        }
        // A corner of each set met: no more than a seam vertex may lose (one) or an anchor keep
        // (two) when the rule is to let go; one more settles it.
        let most = if seam { 1 } else { 2 };
        let fan = &self.topo.fans[v as usize];
        let mut sets = [NONE; 2];
        let mut count = 0;
        for corner in fan {
            let source = self.source_at(corner.face, v);
            if sets[..count].iter().any(|&s| self.same_values(s, source)) {
                continue;
            }
            if count == most {
                return false;
            }
            sets[count] = source;
            count += 1;
        }
        if seam {
            self.seams.on_seam[v as usize] = false;
            return true;
        }
        let bits = |uv: Option<&Vec<[f32; 2]>>, k: u32| uv.map(|uv| uv[k as usize].map(f32::to_bits));
        let uvs = |k: u32| (bits(self.seams.attributes.uvs(), k), bits(self.seams.attributes.uvs1(), k));
        if count != 2 || uvs(sets[0]) != uvs(sets[1]) {
            return false;
        }
        let closed = fan.iter().all(|c| fan.iter().any(|d| d.prev == c.next));
        self.vertices[v as usize].kind = if closed { VertexKind::Interior } else { VertexKind::Boundary };
        true
    }
}

/// Rule 6, pairwise, over the new fan (far edge, unit normal of each face): whether two faces
/// that share an edge turn back onto each other. `spoke`: scratch indexed by vertex.
#[inline]
fn new_fan_folds(spoke: &mut [u32], fan: &[([u32; 2], DVec3)], frozen: bool) -> bool {
    // Rule 6, pairwise: two faces of the new fan that share an edge must not turn back onto each other
    // (a sequence of small per-face normal changes can otherwise fold a pair over). The link
    // condition holds, so the new fan is a disk (or half of one) in which the spoke (merged
    // vertex, x) is the `x` of one face and the `y` of the next: each face finds the face it
    // follows through `spoke`, indexed by vertex, in one pass without a data-dependent branch
    // (checking all pairs cost a mispredicted branch per shared edge). A `spoke` entry left by
    // an earlier check is told apart by the face it names not having that `x`.
    for (i, &([x, _], _)) in fan.iter().enumerate() {
        spoke[x as usize] = i as u32;
    }
    let mut folded = false;
    for &([_, y], n) in fan.iter() {
        let before = fan.get(spoke[y as usize] as usize);
        folded |= before.is_some_and(|&([x, _], m)| (x == y) & (m.dot(n) < FOLD_DOT));
    }
    // Around a frozen survivor the new fan need not be a disk: every pair is looked at.
    let folded = if frozen { folds_pairwise(fan) } else { folded };
    debug_assert!(frozen || folded == folds_pairwise(fan), "spoke pairing disagrees with the pairwise check");
    folded
}

#[cfg(test)]
pub(super) mod tests {
    use super::super::vertex::NormalCone;
    use super::*;

    fn random_unit(rng: &mut crate::rng::SplitMix64) -> DVec3 {
        loop {
            let v = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 2.0 - DVec3::ONE;
            if (0.01..=1.0).contains(&v.length_squared()) {
                return v.normalize();
            }
        }
    }

    #[test]
    fn normal_cone_rounds_down_and_refuses_nan() {
        let mut rng = crate::rng::SplitMix64::new(7);
        for c in [-1.0, -0.9, 0.0, 0.5, 1.0, 1.0 + 1e-12, -1.0 - 1e-12]
            .into_iter()
            .chain((0..1000).map(|_| rng.next_f64() * 2.0 - 1.0))
        {
            assert!(NormalCone::at_least(c).cos() <= c, "{c}");
            assert!(NormalCone::at_least(c).cos() > c - 1e-4, "{c}: too loose");
        }
        assert_eq!(NormalCone::at_least(f64::NAN), NormalCone::NEVER);
        // NEVER rules nothing out, not even a face with the axis' own normal.
        assert!(!NormalCone::NEVER.excludes_fold(DVec3::Z, DVec3::Z));
        assert!(NormalCone::EMPTY.excludes_fold(DVec3::Z, DVec3::Z));
    }

    /// Whenever a cone rules a fold out, no normal it was widened with folds onto the moved face;
    /// and it does rule out most of the harmless cases and none of the folds.
    #[test]
    fn normal_cone_rules_out_only_impossible_folds() {
        let mut rng = crate::rng::SplitMix64::new(11);
        let (mut ruled_out, mut folds) = (0, 0);
        for _ in 0..2000 {
            let axis = random_unit(&mut rng);
            // Faces within a random spread of the axis, as around a vertex.
            let spread = rng.next_f64() * 1.5;
            let faces: Vec<DVec3> =
                (0..6).map(|_| (axis + random_unit(&mut rng) * spread * rng.next_f64()).normalize()).collect();
            let mut cone = NormalCone::EMPTY;
            faces.iter().for_each(|&f| cone.widen(axis, f));
            for _ in 0..8 {
                let n = (axis + random_unit(&mut rng) * rng.next_f64() * 3.0).normalize();
                let folded = faces.iter().any(|f| f.dot(n) < FOLD_DOT);
                folds += folded as usize;
                if cone.excludes_fold(axis, n) {
                    assert!(!folded, "cone {cone:?} around {axis} ruled out a fold of {n}");
                    ruled_out += 1;
                }
            }
        }
        assert!(folds > 100, "the cases include folds ({folds})");
        assert!(ruled_out > 8000, "the cone rules out most harmless cases ({ruled_out} of 16000)");
    }

    // Drawn cases of the rules, each with the one outcome it must have.

    use crate::mesh::Mesh;
    use crate::simplify::SimplifyOptions;

    /// A hexagonal wheel: centre 0, inner ring 1..=6 at radius 1, outer ring 7..=12 at radius 2
    /// (the border). The centre and the inner ring are interior vertices; every far edge of the
    /// centre's fan has a face across it.
    pub(in crate::simplify) fn wheel() -> Mesh {
        let ring = |r: f32, k: u32| {
            let a = (k as f32) * std::f32::consts::FRAC_PI_3;
            [r * a.cos(), r * a.sin(), 0.0]
        };
        let mut positions = vec![[0.0, 0.0, 0.0]];
        positions.extend((0..6).map(|k| ring(1.0, k)));
        positions.extend((0..6).map(|k| ring(2.0, k)));
        let (inner, outer) = (|k: u32| 1 + k % 6, |k: u32| 7 + k % 6);
        let mut triangles = Vec::new();
        for k in 0..6 {
            triangles.push([0, inner(k), inner(k + 1)]);
            triangles.push([inner(k), outer(k), outer(k + 1)]);
            triangles.push([inner(k), outer(k + 1), inner(k + 1)]);
        }
        Mesh::new(positions, triangles).unwrap()
    }

    fn check(mesh: &Mesh, options: &SimplifyOptions, survivor: u32, removed: u32, p: [f32; 3]) -> Result<(), Refusal> {
        let (mut state, _) = State::new(mesh, options);
        let candidate = Candidate { cost: 0.0, survivor, removed, position: p };
        state.is_legal(&candidate).map(|_| ())
    }

    fn on_inner_edge_3_4(scale: f32) -> [f32; 3] {
        // The midpoint of the centre's far edge (3, 4), scaled from the centre.
        let (a, b) = (4.0 * std::f32::consts::FRAC_PI_3, 3.0 * std::f32::consts::FRAC_PI_3);
        [scale * 0.5 * (a.cos() + b.cos()), scale * 0.5 * (a.sin() + b.sin()), 0.0]
    }

    #[test]
    fn a_plain_collapse_is_legal() {
        // The midpoint of the edge: every moved face keeps its side and its shape.
        assert_eq!(check(&wheel(), &SimplifyOptions::default(), 0, 1, [0.5, 0.0, 0.0]), Ok(()));
    }

    #[test]
    fn a_triangular_hole_closes_but_a_tetrahedron_missing_a_face_stays_open() {
        // The wheel without its face (0, 1, 2): the centre and inner vertices 1, 2 bound a hole.
        // Collapsing its edge (0, 1) closes it: 2 is a common neighbour off the edge's one face.
        let mut holed = wheel();
        holed.triangles.retain(|&t| t != [0, 1, 2]);
        let options = SimplifyOptions::default();
        let (mut state, _) = State::new(&holed, &options);
        let legal = state.is_legal(&Candidate { cost: 0.0, survivor: 0, removed: 1, position: [0.5, 0.0, 0.0] });
        assert_eq!(legal.as_ref().map(|l| l.hole), Ok(2));
        state.collapse(legal.unwrap());
        assert!([0, 2].iter().all(|&v| state.kind(v) == VertexKind::Interior));
        // Its other edges close it too (2 into 0 along the edge's face (0, 2, 3)).
        assert_eq!(check(&holed, &options, 0, 2, [0.25, 0.433, 0.0]), Ok(()));
        // A tetrahedron missing a face: closing its hole would leave the third corner two faces
        // that are one face twice.
        let cup = Mesh::new(
            vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            vec![[0, 1, 3], [1, 2, 3], [2, 0, 3]],
        )
        .unwrap();
        for (a, b) in [(0, 1), (1, 2), (2, 0), (1, 0)] {
            assert_eq!(check(&cup, &options, a, b, [0.3, 0.3, 0.0]), Err(Refusal::Link), "{a}-{b}");
        }
        // Locked borders are anchors: no hole closes.
        let locked = SimplifyOptions { boundary: super::super::BoundaryMode::Lock, ..options.clone() };
        assert_eq!(check(&holed, &locked, 0, 1, [0.5, 0.0, 0.0]), Err(Refusal::Link));
    }

    #[test]
    fn a_tetrahedron_cannot_lose_a_vertex() {
        // Rule 3: the link condition holds (the common neighbours are the two opposite
        // vertices), but the merged vertex would keep 2 faces: the solid would flatten.
        let tetrahedron = Mesh::new(
            vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
        )
        .unwrap();
        let options = SimplifyOptions::default();
        for (a, b) in [(0, 1), (1, 2), (2, 3), (3, 0)] {
            assert_eq!(check(&tetrahedron, &options, a, b, [0.2, 0.2, 0.2]), Err(Refusal::TooFewFaces));
        }
    }

    #[test]
    fn a_torus_of_three_by_three_breaks_the_link_condition_everywhere() {
        // Nine vertices of six neighbours each: the ends of every edge share more than the two
        // vertices opposite it, so every collapse would pinch the surface.
        let torus = crate::procedural::torus(3, 3, 0.3);
        let options = SimplifyOptions::default();
        let (state, edges) = State::new(&torus, &options);
        drop(state);
        assert_eq!(edges.len(), 27);
        for [a, b] in edges {
            let p = torus.positions[a as usize];
            assert_eq!(check(&torus, &options, a, b, p), Err(Refusal::Link), "edge {a}–{b}");
        }
    }

    #[test]
    fn a_point_on_a_far_edge_makes_a_needle() {
        // Rule 5: the centre moved onto its far edge (3, 4): that face has no area left.
        assert_eq!(check(&wheel(), &SimplifyOptions::default(), 0, 1, on_inner_edge_3_4(1.0)), Err(Refusal::Needle));
        // Vertex 1 merged at the centre: its face (1, 8, 2) becomes (0, 8, 2), three points on
        // the ray through 2 and 8.
        assert_eq!(check(&wheel(), &SimplifyOptions::default(), 0, 1, [0.0, 0.0, 0.0]), Err(Refusal::Needle));
    }

    #[test]
    fn a_point_past_a_far_edge_flips_or_folds() {
        // Past the far edge (3, 4) the face turns over. Rule 4 refuses the flip; with the normal
        // change allowed up to 180°, rule 6 refuses it as a fold onto the face across the edge.
        let p = on_inner_edge_3_4(1.6);
        assert_eq!(check(&wheel(), &SimplifyOptions::default(), 0, 1, p), Err(Refusal::NormalChange));
        let lenient = SimplifyOptions { max_normal_change_degrees: 180.0, ..Default::default() };
        assert_eq!(check(&wheel(), &lenient, 0, 1, p), Err(Refusal::Fold));
    }

    #[test]
    fn a_fin_freezes_its_ends_which_take_in_only_neighbours_clear_of_it() {
        // Rule 1: a third face on an edge (a fin) makes the edge's ends frozen: they never move or
        // go, and the edge never collapses.
        let mut mesh = wheel();
        let tip = mesh.positions.len() as u32;
        mesh.positions.push([0.5, 0.3, 1.0]);
        mesh.triangles.push([0, 1, tip]);
        // The border turned by −20° so that no face of the inner ring lines up with the centre.
        let (sin, cos) = (-20f32).to_radians().sin_cos();
        for p in &mut mesh.positions[7..13] {
            *p = [p[0] * cos - p[1] * sin, p[0] * sin + p[1] * cos, 0.0];
        }
        let options = SimplifyOptions::default();
        let (state, _) = State::new(&mesh, &options);
        assert_eq!(state.kind(0), VertexKind::Frozen);
        assert_eq!(state.kind(1), VertexKind::Frozen);
        assert!(state.evaluate(0, 1).is_none(), "two frozen ends");
        assert!(state.evaluate(1, 7).is_none(), "a border vertex goes into a frozen one only along the border");
        let into_centre = |removed: u32| {
            let c = state.evaluate(0, removed).expect("a frozen end may survive");
            assert_eq!((c.survivor, c.removed, c.position), (0, removed, mesh.positions[0]));
            check(&mesh, &options, 0, removed, mesh.positions[0])
        };
        // Vertex 2's collapse would hang its faces on the fin's edge (0, 1): refused.
        assert_eq!(into_centre(2), Err(Refusal::Link));
        // Vertex 3's faces attach along (0, 2) and (0, 4), both manifold: legal.
        assert_eq!(into_centre(3), Ok(()));
        assert!(state.evaluate(2, 3).is_some(), "the rest of the wheel still simplifies");
    }
}
