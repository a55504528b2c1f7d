//! The working state of a run and the collapse itself. The state is made of parts, each with one
//! owner: the vertices' blocks ([`VertexData`]), the connectivity ([`Topology`]), the carried
//! values ([`SeamCarrier`]), the checks' scratch ([`Scratch`]), the cost's other terms
//! ([`Terms`]) and what was resolved from the options ([`Config`]). It is built from a prepared
//! mesh ([`State::new`]) and changed only by [`State::collapse`]. The stages above this room
//! (cost, placement, legality, queue, run) read it; the rooms below it own its parts. Other
//! modules of the crate (the refiner's triangle collapse) use the narrow API below, never the
//! fields.

use glam::DVec3;

use crate::fan::Corner;
use crate::mesh::{CornerAttributes, Mesh};
use crate::pm::CollapseRecord;
use crate::prefetch::prefetch;
use crate::quadric::Quadric;

use super::attribute_quadric::WedgeQuadrics;
use super::candidate::Legal;
use super::classify::{Scan, scan_fans};
use super::guard::DistanceGuard;
use super::options::{BoundaryMode, Config, Metric, NormalUpdate, SimplifyOptions};
use super::scratch::Scratch;
use super::seams::SeamCarrier;
use super::sheets::{self, Back};
use super::terms::Terms;
use super::topology::{self, AHEAD, Topology};
use super::vertex::{CONE_MIN_QUALITY, NONE, NormalCone, VertexData, VertexKind, to_f64, triangle_quality};

/// Weight of the boundary-constraint planes relative to the face planes.
const BOUNDARY_WEIGHT: f64 = 10.0;
/// Weight of the seam constraint planes (per side of a seam edge, times its squared length).
/// Chosen by measurement over the textured assets (docs/attributes-report.md): 0.2–0.3 lower the
/// texture error at an unchanged position error; from 0.5 up the position error grows.
const SEAM_WEIGHT: f64 = 0.3;
/// Weight of the constraint planes along an anchor's spokes where the texture coordinates differ
/// on their two sides (a sphere's pole, where each face has its own value). Chosen by
/// measurement (docs/attributes-report.md): a pole's texture error falls with 0.3 and more with 1
/// and 3; from 30 the run stops above its face count on small assets.
const SPOKE_WEIGHT: f64 = 1.0;

/// Mutable state of one run, in parts with one owner each: the algorithm owns it; nothing is left
/// attached to the input mesh.
pub(crate) struct State<'o> {
    /// The options, and what the run resolved from them once.
    pub(super) config: Config<'o>,
    /// Quadric, normal, position and class of each vertex (see [`VertexData`]).
    pub(super) vertices: Vec<VertexData>,
    /// Fans, faces, alive flags, version stamps.
    pub(super) topo: Topology,
    /// The per-corner values carried through the collapses ([`State::carry_attributes`]).
    pub(super) seams: SeamCarrier,
    /// What the legality checks reuse from one candidate to the next.
    pub(super) scratch: Scratch,
    /// The terms beside the quadric cost: distance guard, fan-distance term, attribute quadrics.
    pub(super) terms: Terms,
    /// Vertices on a border or frozen at the start: a collapse that takes one face instead of two
    /// removes one of them, so they bound how far the run's log outgrows half the faces removed.
    pub(super) open_vertices: usize,
    /// The vertices the scan found frozen (non-manifold or inconsistently oriented neighbourhoods).
    pub(super) frozen_at_start: Vec<u32>,
    /// Per face, the back set aside for it (`super::sheets`): a face with one counts twice
    /// towards the target, and the output writes it again. Empty when none was.
    pub(super) backs: Vec<Back>,
}

/// Each vertex's block with its position, its area-weighted quadric of the planes of its faces and
/// the sum of their unit normals (Gouraud, not yet normalised), summed in face order; and each
/// face's unit normal for the normal cones: NaN where the face is too poor for a cone (NaN makes
/// the cone unusable).
fn face_pass(mesh: &Mesh) -> (Vec<VertexData>, Vec<DVec3>) {
    let mut vertices: Vec<VertexData> =
        mesh.positions.iter().map(|&position| VertexData { position, ..Default::default() }).collect();
    let mut face_units = Vec::with_capacity(mesh.face_count());
    for (f, t) in mesh.triangles.iter().enumerate() {
        if let Some(t) = mesh.triangles.get(f + AHEAD) {
            t.iter().for_each(|&v| vertices[v as usize].prefetch());
        }
        let [pa, pb, pc] = mesh.triangle_points(f);
        let n = (pb - pa).cross(pc - pa);
        let area = 0.5 * n.length();
        if area == 0.0 {
            face_units.push(DVec3::NAN);
            continue;
        }
        let unit = n / (2.0 * area);
        let usable = triangle_quality(2.0 * area, pa, pb, pc) >= CONE_MIN_QUALITY;
        face_units.push(if usable { unit } else { DVec3::NAN });
        // `n.normalize()` rather than `unit` (equal up to the last bit): the collapse order, and
        // so the documented figures, follow these exact bits (docs/simplify-report.md,
        // sensitivity; engine/tests/digest.rs holds them).
        let q = Quadric::from_plane(n.normalize(), pa, area);
        for &v in t {
            let vertex = &mut vertices[v as usize];
            vertex.quadric += q;
            vertex.normal += unit;
        }
    }
    (vertices, face_units)
}

/// Adds to `a` and `b` the constraint plane through edge (a, b) perpendicular to face `f`,
/// weighted by `weight` times the edge's squared length (a border or a seam keeps its line).
fn add_edge_plane(vertices: &mut [VertexData], mesh: &Mesh, f: usize, a: u32, b: u32, weight: f64) {
    let [p0, p1, p2] = mesh.triangle_points(f);
    let face_normal = (p1 - p0).cross(p2 - p0).normalize_or_zero();
    let (pa, pb) = (mesh.point(a), mesh.point(b));
    let edge = pb - pa;
    let plane_normal = edge.cross(face_normal).normalize_or_zero();
    if plane_normal == DVec3::ZERO {
        return;
    }
    let q = Quadric::constraint(plane_normal, pa, weight * edge.length_squared());
    vertices[a as usize].quadric += q;
    vertices[b as usize].quadric += q;
}

impl<'o> State<'o> {
    /// Working state for `mesh` (prepared: no repeated-index faces, no unreferenced vertices):
    /// fans, vertex classes, area-weighted quadrics with boundary constraint planes, Gouraud
    /// normals. Also returns every undirected edge once, as `[low, high]`, sorted.
    pub(crate) fn new(mesh: &Mesh, options: &'o SimplifyOptions) -> (State<'o>, Vec<[u32; 2]>) {
        State::with_tracking(mesh, options, true)
    }

    /// [`State::new`], keeping the triangle array current through the collapses or (without
    /// `track`) leaving it empty until [`State::rebuild_triangles`].
    pub(crate) fn with_tracking(mesh: &Mesh, options: &'o SimplifyOptions, track: bool) -> (State<'o>, Vec<[u32; 2]>) {
        State::with_carried(mesh, options, track, None::<fn(usize, &mut VertexData)>)
    }

    /// [`State::with_tracking`], then `carry` given each vertex's block (its class, quadric and
    /// unit normal from `mesh`, border planes included) to replace what an earlier run knows
    /// better, before the normal cones are made around the normals it leaves (`super::halves`).
    pub(super) fn with_carried(
        mesh: &Mesh,
        options: &'o SimplifyOptions,
        track: bool,
        carry: Option<impl Fn(usize, &mut VertexData)>,
    ) -> (State<'o>, Vec<[u32; 2]>) {
        let vertex_count = mesh.vertex_count();
        // Two passes over the faces that need nothing of each other, side by side where the pool
        // has threads for them (`crate::parallel`): the fans and their scan (classes and edges),
        // and the quadrics and normals.
        let ((fans, Scan { kind, edges, boundary_edges }), (mut vertices, face_units)) = crate::parallel::join(
            mesh.face_count(),
            || {
                let fans = topology::build_fans(mesh);
                let scan = scan_fans(&fans);
                (fans, scan)
            },
            || face_pass(mesh),
        );
        let lock = options.boundary == BoundaryMode::Lock;
        let (mut open_vertices, mut frozen_at_start) = (0, Vec::new());
        for (v, (vertex, kind)) in vertices.iter_mut().zip(kind).enumerate() {
            open_vertices += matches!(kind, VertexKind::Boundary | VertexKind::Frozen) as usize;
            if kind == VertexKind::Frozen {
                frozen_at_start.push(v as u32);
            }
            vertex.kind = match kind {
                VertexKind::Boundary if lock => VertexKind::Anchored,
                kind => kind,
            };
            vertex.normal = vertex.normal.normalize_or_zero();
        }
        // The quadrics take, besides their faces' planes, a plane through each border edge and
        // perpendicular to its face: a border keeps its line.
        for &(a, b, f) in &boundary_edges {
            add_edge_plane(&mut vertices, mesh, f as usize, a, b, BOUNDARY_WEIGHT);
        }
        if let Some(carry) = carry {
            vertices.iter_mut().enumerate().for_each(|(v, vertex)| carry(v, vertex));
        }
        // Each vertex's normal cone takes in the unit normals of its faces (the cones need every
        // vertex normal first).
        for (vertex, fan) in vertices.iter_mut().zip(&fans) {
            for corner in fan {
                vertex.cone.widen(vertex.normal, face_units[corner.face as usize]);
            }
        }
        let mut state = State {
            config: Config::new(options),
            vertices,
            topo: Topology::new(mesh, fans, track),
            seams: SeamCarrier::default(),
            scratch: Scratch::new(vertex_count),
            terms: Terms {
                guard: None,
                // Off with texture coordinates: on the textured assets it raised the position
                // error at 2-5x meshoptimizer's time (docs/attributes-report.md).
                fan_term: match options.metric {
                    Metric::Melax => 0.0,
                    _ if options.guard > 0.0 || mesh.corners.uvs().is_some() => 0.0,
                    _ => options.distance_term,
                },
                per_area: false,
                term_base: mesh.face_count(),
                wedges: None,
            },
            open_vertices,
            frozen_at_start,
            backs: Vec::new(),
        };
        if options.guard > 0.0 {
            state.terms.guard = DistanceGuard::new(mesh, &state.topo.fans);
        }
        state.terms.per_area = state.terms.has_distance_term() && options.metric != Metric::Melax;
        (state, edges)
    }

    /// Carries `mesh`'s per-corner attributes (the mesh the state was made from) through the run.
    /// A collapse gives each corner of the removed vertex the survivor's values on the same side:
    /// with one set of values at the removed vertex, the survivor's in the faces of the edge
    /// (which must agree); on a seam (two sets), the edge must be a seam edge, and each side takes
    /// the survivor's values on that side ([`State::seam_sides`], rule 7). A vertex with three or
    /// more sets (where seams meet) is anchored: it never moves or goes, but takes in neighbours,
    /// until collapses leave it two sets that differ in normals only ([`State::relax`]). No value
    /// is invented and none crosses a seam.
    /// (Values interpolated at the new position are later work.) Needs the triangle array, so it
    /// is kept current from here.
    pub(crate) fn carry_attributes(&mut self, mesh: &Mesh) {
        if mesh.corners.is_empty() {
            return;
        }
        self.seams.attributes = mesh.corners.clone();
        self.seams.value_id = mesh.corners.value_ids(&mesh.triangles, mesh.vertex_count());
        self.seams.corner_source = (0..3 * mesh.face_count() as u32).collect();
        if !self.topo.track_triangles {
            self.topo.triangles = mesh.triangles.clone();
            self.topo.track_triangles = true;
        }
        let mut seen = vec![[NONE; 2]; mesh.vertex_count()];
        for (k, &v) in mesh.triangles.iter().flatten().enumerate() {
            let sets = &mut seen[v as usize];
            let known = |s: u32| s != NONE && self.seams.value_id[s as usize] == self.seams.value_id[k];
            if known(sets[0]) || known(sets[1]) {
                continue;
            }
            if sets[0] == NONE {
                sets[0] = k as u32;
            } else if sets[1] == NONE {
                sets[1] = k as u32;
            } else if self.vertices[v as usize].kind != VertexKind::Frozen {
                self.vertices[v as usize].kind = VertexKind::Anchored;
            }
        }
        let diagonal2 = mesh.bounds().map_or(0.0, |b| b.diagonal().powi(2));
        let w = self.config.options.attribute_weights_for(mesh);
        self.terms.wedges =
            WedgeQuadrics::new(mesh, &self.seams.value_id, [w.uv, w.normal, w.color].map(|w| w * diagonal2));
        // (A survivor keeps its flag: a seam vertex goes only into one on the same seam.)
        self.seams.on_seam = seen.iter().map(|sets| sets[1] != NONE).collect();
        self.add_seam_planes(mesh);
        if self.config.options.lock_seams {
            for (vertex, &seam) in self.vertices.iter_mut().zip(&self.seams.on_seam) {
                if seam && vertex.kind != VertexKind::Frozen {
                    vertex.kind = VertexKind::Anchored;
                }
            }
        }
    }

    /// Constraint planes along the seams, as along the borders: through each seam edge and
    /// perpendicular to each face beside it. A seam vertex moves only along its seam (rule 7), and
    /// with these a collapse along a seam that turns costs what it moves the seam by, so that a
    /// chart keeps its outline on the surface (without them a seam loop on a flat stretch, a small
    /// chart such as an eye's, shrinks to a triangle for almost nothing and its texture spreads
    /// over the faces around).
    ///
    /// Also along an anchor's spokes (edges to a vertex off every seam) whose two faces give the
    /// anchor different texture coordinates: at a sphere's pole each face has its own, and a
    /// collapse around the pole that merges two of those faces' wedges (cheap in position: the
    /// faces there are small) stretches one value over both; the planes charge it what it moves
    /// the spoke by.
    fn add_seam_planes(&mut self, mesh: &Mesh) {
        for (f, t) in mesh.triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                let anchor = |v: u32| self.vertices[v as usize].kind == VertexKind::Anchored;
                // The anchor's corner of a spoke (its index among f's corners), or None for an edge
                // along a seam.
                let spoke = match (self.seams.on_seam[a as usize], self.seams.on_seam[b as usize]) {
                    (true, true) => None,
                    (true, false) if anchor(a) => Some((a, k)),
                    (false, true) if anchor(b) => Some((b, (k + 1) % 3)),
                    _ => continue,
                };
                // The face across (a, b), and whether its corners at a and b carry other values.
                let across = self.topo.fans[a as usize].iter().find(|d| d.face != f as u32 && d.touches(b));
                let Some(d) = across else { continue };
                let g = d.face;
                let same = self.same_values(3 * f as u32 + k as u32, self.source_at(g, a))
                    && self.same_values(3 * f as u32 + (k as u32 + 1) % 3, self.source_at(g, b));
                if same {
                    continue;
                }
                let weight = match (spoke, &mesh.corners.uvs()) {
                    (None, _) => SEAM_WEIGHT,
                    (Some((v, corner)), Some(uvs)) if uvs[3 * f + corner] != uvs[self.source_at(g, v) as usize] => {
                        SPOKE_WEIGHT
                    }
                    // A spoke across which only other values (normals: a hard edge) change.
                    (Some(_), _) => continue,
                };
                add_edge_plane(&mut self.vertices, mesh, f, a, b, weight);
            }
        }
    }

    /// The live vertices that never move: frozen (non-manifold) ones and anchors.
    pub(crate) fn frozen_vertices(&self) -> usize {
        (self.vertices.iter().zip(&self.topo.vertex_alive))
            .filter(|&(v, &alive)| alive && matches!(v.kind, VertexKind::Frozen | VertexKind::Anchored))
            .count()
    }

    /// The surviving mesh: live vertices in input order, live faces in input order.
    pub(crate) fn output_mesh(&self) -> Mesh {
        let mut new_index = vec![NONE; self.vertices.len()];
        let mut positions = Vec::new();
        for (v, slot) in new_index.iter_mut().enumerate() {
            if self.topo.vertex_alive[v] && !self.topo.fans[v].is_empty() {
                *slot = positions.len() as u32;
                positions.push(self.vertices[v].position);
            }
        }
        let live = || (0..self.topo.triangles.len()).filter(|&f| self.topo.face_alive[f]);
        let triangles: Vec<[u32; 3]> = live().map(|f| self.topo.triangles[f].map(|v| new_index[v as usize])).collect();
        let corners = if self.seams.corner_source.is_empty() {
            CornerAttributes::default()
        } else {
            self.seams
                .attributes
                .pick(live().flat_map(|f| (0..3).map(move |k| self.seams.corner_source[3 * f + k] as usize)))
        };
        let mesh = Mesh { positions, triangles, corners };
        debug_assert!(mesh.check().is_ok());
        mesh
    }

    pub(crate) fn point(&self, v: u32) -> DVec3 {
        to_f64(self.vertices[v as usize].position)
    }

    pub(crate) fn face_normal(&self, f: u32) -> DVec3 {
        debug_assert!(self.topo.track_triangles, "the triangle array is not being kept current");
        let [a, b, c] = self.topo.triangles[f as usize];
        let (pa, pb, pc) = (self.point(a), self.point(b), self.point(c));
        (pb - pa).cross(pc - pa).normalize_or_zero()
    }

    /// Mean of the unit normals of the faces around `v` (Gouraud).
    pub(crate) fn fan_normal(&self, v: u32) -> DVec3 {
        let p = self.point(v);
        let sum: DVec3 = self.topo.fans[v as usize]
            .iter()
            .map(|c| (self.point(c.next) - p).cross(self.point(c.prev) - p).normalize_or_zero())
            .sum();
        sum.normalize_or_zero()
    }

    /// Asks the cache, all at once, for what the checks, the collapse of (a, b) and the re-ranking
    /// of its edges will read of the ring around the edge: each neighbour's block (both lines) and
    /// fan. The misses then overlap instead of following one another through the data-dependent
    /// branches of the checks (real loads did this too, less well: they stall the core; docs/history/benchmarks-log.md).
    #[inline]
    pub(super) fn prefetch_ring(&self, a: u32, b: u32) {
        // Not a nor b (each is a `next` around the other: their data is in cache already). A
        // hint that has to wait for a free fill buffer stalls the core, so none is wasted.
        for (v, other) in [(a, b), (b, a)] {
            for corner in &self.topo.fans[v as usize] {
                let x = corner.next;
                if x != other {
                    self.vertices[x as usize].prefetch();
                    self.topo.fans[x as usize].prefetch();
                }
            }
        }
    }

    /// Asks the cache for what checking the collapse of (a, b) reads first: the version stamps,
    /// both lines of each endpoint's block and both lines of each fan (the fan after `v`'s starts
    /// where `v`'s ends). A hint only: it never faults and changes nothing.
    #[inline]
    pub(super) fn prefetch_edge(&self, a: u32, b: u32) {
        for v in [a as usize, b as usize] {
            prefetch(&self.topo.version[v]);
            self.vertices[v].prefetch();
            self.topo.fans[v].prefetch();
        }
    }

    /// Applies a legal collapse and returns its log record.
    pub(crate) fn collapse(&mut self, legal: Legal) -> CollapseRecord {
        let scratch_is_current = legal.check == self.scratch.check_id;
        let c = &legal.candidate;
        let (a, b) = (c.survivor, c.removed);
        let (shared, shared_count) = self.edge_corners(a, b);
        let mut record = CollapseRecord {
            survivor: a,
            removed: b,
            left: NONE,
            right: NONE,
            left_face: NONE,
            right_face: NONE,
            hole: legal.hole,
            survivor_position: self.vertices[a as usize].position,
            removed_position: self.vertices[b as usize].position,
            collapsed_position: c.position,
            error: 0.0,
        };
        let dead = self.topo.remove_edge_faces(b, &shared[..shared_count], &mut record);
        // Rule 7's mapping of b's values to a's (checked legal: `is_legal` refused it otherwise).
        let sides = if self.seams.corner_source.is_empty() {
            None
        } else {
            let count = if dead[1] == NONE { 1 } else { 2 };
            let sides = self.seam_sides(a, b, &dead[..count]).expect("rule 7 was checked");
            if let Some(q) = &mut self.terms.wedges {
                q.merge(sides);
            }
            Some(sides)
        };
        let is_dead = |d: &Corner| (d.face == dead[0]) | (d.face == dead[1]);
        self.topo.fans[a as usize].retain(|d| !is_dead(d));
        let moved = std::mem::take(&mut self.topo.fans[b as usize]);
        let count_a = self.topo.fans[a as usize].len() as f64;
        // b's fan holds each face at b once, the shared faces among them.
        let count_b = moved.len() - shared_count;
        debug_assert_eq!(count_b, moved.iter().filter(|d| !is_dead(d)).count());
        for corner in moved.iter().filter(|d| !is_dead(d)) {
            let f = corner.face;
            if self.topo.track_triangles {
                for (k, slot) in self.topo.triangles[f as usize].iter_mut().enumerate() {
                    if *slot == b {
                        *slot = a;
                        if let Some([(b_first, a_first), (_, a_second)]) = sides {
                            let at = 3 * f as usize + k;
                            let first = self.seams.value_id[self.seams.corner_source[at] as usize]
                                == self.seams.value_id[b_first as usize];
                            if self.config.options.record_progressive {
                                self.seams.journal.push((f, self.seams.corner_source[at]));
                            }
                            self.seams.corner_source[at] = if first { a_first } else { a_second };
                        }
                    }
                }
            }
            // The face's corners at its two other vertices name b: they now name a.
            for x in [corner.next, corner.prev] {
                let fan = &mut self.topo.fans[x as usize];
                if let Some(d) = fan.find_face(f).map(|i| &mut fan[i]) {
                    // One of the two names b: which one is as good as random, so no branch.
                    d.next = if d.next == b { a } else { d.next };
                    d.prev = if d.prev == b { a } else { d.prev };
                }
            }
            self.topo.fans[a as usize].push(*corner);
        }
        self.topo.vertex_alive[b as usize] = false;
        if legal.hole != NONE {
            // The hole closed: the merged vertex's fan and the hole's third corner's are closed now
            // (the caller ranks the corner's edges again: their class changed).
            self.vertices[a as usize].kind = VertexKind::Interior;
            self.vertices[legal.hole as usize].kind = VertexKind::Interior;
            self.topo.version[legal.hole as usize] = self.topo.version[legal.hole as usize].wrapping_add(1);
        }
        let removed = self.vertices[b as usize];
        let survivor = &mut self.vertices[a as usize];
        survivor.position = c.position;
        survivor.quadric += removed.quadric;
        // The linear estimate, unless it cancels out (opposite normals): then Gouraud on the new fan.
        let linear = (survivor.normal * count_a + removed.normal * count_b as f64).normalize_or_zero();
        self.vertices[a as usize].normal = match self.config.options.normals {
            NormalUpdate::Linear if linear != DVec3::ZERO => linear,
            NormalUpdate::Linear | NormalUpdate::Recompute => self.fan_normal(a),
        };
        self.update_cones(a, scratch_is_current);
        if let Some(guard) = &mut self.terms.guard {
            guard.follow(&self.topo, &self.vertices, a, b);
        }
        self.topo.version[a as usize] = self.topo.version[a as usize].wrapping_add(1);
        self.topo.version[b as usize] = self.topo.version[b as usize].wrapping_add(1);
        if sides.is_some() && self.config.options.record_progressive {
            self.seams.journal_ends.push(self.seams.journal.len() as u32);
        }
        record
    }

    /// The class of vertex `v`, fixed at the start.
    pub(crate) fn kind(&self, v: u32) -> VertexKind {
        self.vertices[v as usize].kind
    }

    /// Faces on edge (a, b), as corners of `a`'s fan, and how many there are.
    #[inline]
    pub(super) fn edge_corners(&self, a: u32, b: u32) -> ([Corner; 2], usize) {
        self.topo.edge_corners(a, b)
    }

    /// The one-ring of `v`, sorted, into `out`.
    pub(crate) fn neighbours(&self, v: u32, out: &mut Vec<u32>) {
        self.topo.neighbours(v, out)
    }

    /// Corners of face `f` (kept current only for a state made with [`State::new`]).
    pub(crate) fn triangle(&self, f: u32) -> [u32; 3] {
        self.topo.triangle(f)
    }

    /// Number of vertices the state was made with (alive or not).
    pub(crate) fn vertex_count(&self) -> usize {
        self.vertices.len()
    }

    /// Whether face `f` is still in the mesh.
    pub(crate) fn is_face_alive(&self, f: u32) -> bool {
        self.topo.is_face_alive(f)
    }

    /// Whether vertex `v` is still in the mesh.
    pub(crate) fn is_vertex_alive(&self, v: u32) -> bool {
        self.topo.is_vertex_alive(v)
    }

    /// The live faces around vertex `v`.
    pub(crate) fn faces_around(&self, v: u32) -> impl Iterator<Item = u32> + '_ {
        self.topo.faces_around(v)
    }

    /// Brings the faces' corners up to date after a run without tracking ([`Topology::rebuild_triangles`]).
    pub(crate) fn rebuild_triangles(&mut self, mesh: &Mesh, log: &[CollapseRecord]) {
        self.topo.rebuild_triangles(mesh, log)
    }

    /// Whether input corners `x` and `y`, of the same vertex, carry the same values.
    #[inline]
    pub(super) fn same_values(&self, x: u32, y: u32) -> bool {
        self.seams.same_values(x, y)
    }

    /// The input corner whose values vertex `v` has in face `f`.
    pub(super) fn source_at(&self, f: u32, v: u32) -> u32 {
        self.seams.source_at(&self.topo, f, v)
    }

    /// Rule 7's mapping of b's values to a's for collapsing `b` into `a` over `dead`
    /// ([`SeamCarrier::seam_sides`]).
    pub(super) fn seam_sides(&self, a: u32, b: u32, dead: &[u32]) -> Option<[(u32, u32); 2]> {
        self.seams.seam_sides(&self.topo, a, b, dead)
    }

    /// Rule 7 in texture space ([`SeamCarrier::texture_keeps_orientation`]).
    pub(super) fn texture_keeps_orientation(&self, b: u32, dead: &[u32; 2], sides: [(u32, u32); 2]) -> bool {
        self.seams.texture_keeps_orientation(&self.topo, b, dead, sides)
    }

    /// A fresh stamp for the scratch marks.
    pub(super) fn next_stamp(&mut self) -> u32 {
        self.scratch.next_stamp()
    }

    /// Whether queue keys leave out a distance term that candidates pay at the top of the queue.
    pub(super) fn has_distance_term(&self) -> bool {
        self.terms.has_distance_term()
    }
    /// Keeps the [`NormalCone`]s exact after `a` moved and took over faces: each face around `a`
    /// widens the cones of its two other corners, and `a`'s own cone is rebuilt around its new
    /// normal from these faces alone (they are all its faces). With `checked`, the new normals are
    /// the ones [`State::is_legal`] just computed for this collapse (its scratch holds exactly the
    /// faces of `a`'s new fan); otherwise they are computed here.
    pub(super) fn update_cones(&mut self, a: u32, checked: bool) {
        let axis = self.vertices[a as usize].normal;
        let mut cone = NormalCone::EMPTY;
        if checked {
            debug_assert_eq!(self.scratch.fan_scratch.len(), self.topo.fans[a as usize].len());
            for &([x, y], n) in &self.scratch.fan_scratch {
                cone.widen(axis, n);
                for v in [x, y] {
                    let vertex = &mut self.vertices[v as usize];
                    vertex.cone.widen(vertex.normal, n);
                }
            }
            self.vertices[a as usize].cone = cone;
            return;
        }
        let p = self.point(a);
        for i in 0..self.topo.fans[a as usize].len() {
            let Corner { next: x, prev: y, .. } = self.topo.fans[a as usize][i];
            let (px, py) = (self.point(x), self.point(y));
            let cross = (px - p).cross(py - p);
            let area2 = cross.length();
            // `is_legal` refuses collapses that make a face this poor; a caller that skipped it
            // gets cones that never rule a fold out, not wrong ones.
            if area2 == 0.0 || triangle_quality(area2, p, px, py) < CONE_MIN_QUALITY {
                cone = NormalCone::NEVER;
                self.vertices[x as usize].cone = NormalCone::NEVER;
                self.vertices[y as usize].cone = NormalCone::NEVER;
                continue;
            }
            let n = cross / area2;
            cone.widen(axis, n);
            for v in [x, y] {
                let vertex = &mut self.vertices[v as usize];
                vertex.cone.widen(vertex.normal, n);
            }
        }
        self.vertices[a as usize].cone = cone;
    }

    /// The appearance part of collapsing `b` into `a` at `p` ([`WedgeQuadrics::attribute_error`]):
    /// 0 without attribute quadrics.
    #[inline]
    pub(super) fn attribute_error(&self, a: u32, b: u32, p: DVec3) -> f64 {
        self.terms.wedges.as_ref().map_or(0.0, |q| q.attribute_error(&self.topo, &self.seams, a, b, p))
    }

    /// The faces face `f` stands for in the output: itself and its back, if one was set aside.
    #[inline]
    pub(super) fn output_faces(&self, f: u32) -> usize {
        sheets::output_faces(&self.backs, f)
    }

    /// The faces of `mesh` (the state's) stacked on an earlier face with its values
    /// ([`sheets::stacked_faces`]).
    pub(super) fn stacked_faces(&self, mesh: &Mesh) -> Vec<sheets::StackedFace> {
        sheets::stacked_faces(&self.topo, &self.frozen_at_start, mesh)
    }
}
