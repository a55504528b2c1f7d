//! The working state of a run and the collapse itself: fans, per-vertex data, alive flags and
//! version stamps, built from a prepared mesh ([`State::new`]) and changed only by
//! [`State::collapse`]. Other modules of the crate (the refiner's triangle collapse) use the
//! narrow API below, never the fields.

use glam::DVec3;

use crate::fan::{Corner, FanSlot};
use crate::mesh::{CornerAttributes, Mesh};
use crate::pm::CollapseRecord;
use crate::prefetch::prefetch;
use crate::quadric::Quadric;

use super::attribute_quadric::WedgeQuadrics;
use super::classify::{Scan, VertexKind, scan_fans};
use super::guard::DistanceGuard;
use super::legality::{CONE_MIN_QUALITY, Legal, NormalCone, triangle_quality};
use super::options::{BoundaryMode, Metric, NormalUpdate, SimplifyOptions};

/// Weight of the boundary-constraint planes relative to the face planes.
const BOUNDARY_WEIGHT: f64 = 10.0;
/// Weight of the seam constraint planes (per side of a seam edge, times its squared length).
/// Chosen by measurement (docs/attributes-report.md): 0.2–0.3 lower the texture error on Duck,
/// CesiumMan, Fox and fuze at an unchanged position error; from 0.5 up Duck's and spot's position
/// error grows (spot 1.3× meshoptimizer's at 1).
const SEAM_WEIGHT: f64 = 0.3;
/// Weight of the constraint planes along an anchor's spokes where the texture coordinates differ
/// on their two sides (a sphere's pole, where each face has its own value). Chosen by
/// measurement (docs/attributes-report.md): capsule's texture error falls with 0.3 and falls more
/// with 1 and 3; from 30 Fox stops above its face count.
const SPOKE_WEIGHT: f64 = 1.0;

pub(crate) const NONE: u32 = u32::MAX;

/// Mutable state of one run: the algorithm owns it; nothing is left attached to the input mesh.
pub(crate) struct State<'o> {
    pub(super) options: &'o SimplifyOptions,
    /// Quadric, normal, position and class of each vertex (see [`VertexData`]).
    pub(super) vertices: Vec<VertexData>,
    /// Each face's corners, kept current by every collapse while `track_triangles` is set; the
    /// simplifier's own loop does without (the fans carry what the loop reads: the state is made
    /// without the array) and builds it once at the end from the log
    /// ([`State::rebuild_triangles`]).
    pub(super) triangles: Vec<[u32; 3]>,
    pub(super) track_triangles: bool,
    pub(super) face_alive: Vec<bool>,
    /// The live faces around each vertex, with their other two corners.
    pub(super) fans: Vec<FanSlot>,
    pub(super) vertex_alive: Vec<bool>,
    pub(super) version: Vec<u32>,
    /// Scratch marks for the link condition.
    pub(super) mark: Vec<u32>,
    pub(super) mark_stamp: u32,
    /// Scratch for the fold check: the two other corners and the new unit normal of each face.
    pub(super) fan_scratch: Vec<([u32; 2], DVec3)>,
    /// Scratch for the fold check: for a ring vertex x, the index in `fan_scratch` of the face
    /// whose far edge starts at x (valid only where that face's far edge does start at x).
    pub(super) spoke: Vec<u32>,
    /// Vertices on a border or frozen at the start: a collapse that takes one face instead of two
    /// removes one of them, so they bound how far the run's log outgrows half the faces removed.
    pub(super) open_vertices: usize,
    /// The vertices the scan found frozen (non-manifold or inconsistently oriented neighbourhoods).
    pub(super) frozen_at_start: Vec<u32>,
    /// Per face, the back set aside for it (`super::sheets`): a face with one counts twice
    /// towards the target, and the output writes it again. Empty when none was.
    pub(super) backs: Vec<super::sheets::Back>,
    /// Counts the calls of `is_legal`: a [`Legal`] token from the latest call (the one whose new
    /// face normals `fan_scratch` holds) carries the current count.
    pub(super) check_id: u32,
    pub(super) cos_max_normal_change: f64,
    /// What the distance guard measures with, when it is on.
    pub(super) guard: Option<DistanceGuard>,
    /// Weight of the fan-distance term (`fan_term`): the options' where it applies (a quadric
    /// cost, the distance guard off, no texture coordinates), else 0.
    pub(super) fan_term: f64,
    /// Whether the queue ranks quadric costs per unit of the area behind them
    /// ([`State::ranked_cost`]): with a distance term (the fan-distance term or the guard's), not
    /// with the paper's cost alone.
    pub(super) per_area: bool,
    /// The face count whose share [`super::fan_term::FAN_TERM_FROM`] the run removes before the
    /// fan-distance term is measured: the mesh's own, or the whole input's for the second stage of
    /// a run in halves (`super::halves`).
    pub(super) term_base: usize,
    /// Per-corner attributes carried through the collapses ([`State::carry_attributes`]): the
    /// input's values, and for each current corner (3 per face) the input corner whose values it
    /// has. Empty when the input has none (the collapse then pays nothing for them).
    pub(super) attributes: CornerAttributes,
    /// Per input corner, a number shared exactly by the corners of its vertex with the same
    /// values ([`CornerAttributes::value_ids`]): every comparison of values is between corners of
    /// one vertex (a corner's values are always its vertex's own).
    pub(super) value_id: Vec<u32>,
    pub(super) corner_source: Vec<u32>,
    /// Per vertex, with attributes: whether it has two sets of values (on a seam). Rule 7 lets
    /// such a vertex go only into another on the seam, so with one end on a seam, the ranking
    /// keeps that end in place ([`State::choose`]) rather than picking a collapse rule 7 refuses.
    pub(super) on_seam: Vec<bool>,
    /// The attribute quadrics of the wedges ([`WedgeQuadrics`]), when attributes are carried and
    /// weighted.
    pub(super) wedges: Option<WedgeQuadrics>,
    /// With attributes and a progressive mesh to record: per collapse, the corners of the removed
    /// vertex that took new values, as (face, the input corner whose values it had before), and
    /// where each collapse's entries end. The vertex splits restore them.
    pub(crate) journal: Vec<(u32, u32)>,
    pub(crate) journal_ends: Vec<u32>,
}

/// What ranking an edge reads of each endpoint, in one 128-byte block (two adjacent cache lines)
/// rather than a line or two in each of four arrays. The cost is evaluated about twelve times per
/// collapse, mostly with a neighbour whose data is not in cache: one block halves the misses where
/// the vertex order is far from the surface order (measured in docs/history/benchmarks-log.md).
#[derive(Debug, Clone, Copy, Default)]
#[repr(C, align(64))]
pub(super) struct VertexData {
    pub(super) quadric: Quadric,
    /// Unit vertex normal: Gouraud at the start, then the linear estimate (or the recomputed mean).
    pub(super) normal: DVec3,
    pub(super) position: [f32; 3],
    pub(super) kind: VertexKind,
    /// A lower bound on the cosine between `normal` and the unit normal of every live face around
    /// the vertex ([`NormalCone`]), in the block's last spare bytes.
    pub(super) cone: NormalCone,
}

const _: () = assert!(std::mem::size_of::<VertexData>() == 128);

impl VertexData {
    /// Asks the cache for both lines of the block (the quadric starts the first; normal, position,
    /// class and cone fill the second).
    #[inline]
    pub(crate) fn prefetch(&self) {
        prefetch(&self.quadric);
        prefetch(&self.position);
    }
}

/// The passes over the faces below write to their corners' fans and blocks, in the input's vertex
/// order, which can be far from its face order: each asks for the data of the face `AHEAD` places
/// on while it works on this one.
const AHEAD: usize = 8;

/// The faces around each vertex, in face order.
fn build_fans(mesh: &Mesh) -> Vec<FanSlot> {
    let mut fans = vec![FanSlot::default(); mesh.vertex_count()];
    for (f, &[x, y, z]) in mesh.triangles.iter().enumerate() {
        if let Some(t) = mesh.triangles.get(f + AHEAD) {
            t.iter().for_each(|&v| fans[v as usize].prefetch());
        }
        let face = f as u32;
        fans[x as usize].push(Corner { face, next: y, prev: z });
        fans[y as usize].push(Corner { face, next: z, prev: x });
        fans[z as usize].push(Corner { face, next: x, prev: y });
    }
    fans
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

#[inline]
pub(super) fn to_f64(p: [f32; 3]) -> DVec3 {
    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

#[inline]
pub(super) fn to_f32(p: DVec3) -> [f32; 3] {
    [p.x as f32, p.y as f32, p.z as f32]
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
                let fans = build_fans(mesh);
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
            options,
            vertices,
            triangles: if track { mesh.triangles.clone() } else { Vec::new() },
            track_triangles: track,
            face_alive: vec![true; mesh.face_count()],
            fans,
            vertex_alive: vec![true; vertex_count],
            version: vec![0; vertex_count],
            mark: vec![0; vertex_count],
            mark_stamp: 0,
            fan_scratch: Vec::new(),
            spoke: vec![0; vertex_count],
            open_vertices,
            frozen_at_start,
            backs: Vec::new(),
            check_id: 0,
            cos_max_normal_change: options.max_normal_change_degrees.to_radians().cos(),
            guard: None,
            // Off with texture coordinates: on the textured assets it raised the position error on
            // capsule and Lantern at 2-5x meshoptimizer's time (docs/attributes-report.md).
            fan_term: match options.metric {
                Metric::Melax => 0.0,
                _ if options.guard > 0.0 || mesh.corners.uvs.is_some() => 0.0,
                _ => options.distance_term,
            },
            per_area: false,
            term_base: mesh.face_count(),
            attributes: CornerAttributes::default(),
            value_id: Vec::new(),
            corner_source: Vec::new(),
            on_seam: Vec::new(),
            wedges: None,
            journal: Vec::new(),
            journal_ends: Vec::new(),
        };
        if options.guard > 0.0 {
            state.guard = DistanceGuard::new(mesh, &state.fans);
        }
        state.per_area = state.has_distance_term() && options.metric != Metric::Melax;
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
        self.attributes = mesh.corners.clone();
        self.value_id = mesh.corners.value_ids(&mesh.triangles, mesh.vertex_count());
        self.corner_source = (0..3 * mesh.face_count() as u32).collect();
        if !self.track_triangles {
            self.triangles = mesh.triangles.clone();
            self.track_triangles = true;
        }
        let mut seen = vec![[NONE; 2]; mesh.vertex_count()];
        for (k, &v) in mesh.triangles.iter().flatten().enumerate() {
            let sets = &mut seen[v as usize];
            let known = |s: u32| s != NONE && self.value_id[s as usize] == self.value_id[k];
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
        let w = self.options.attribute_weights;
        self.wedges = WedgeQuadrics::new(mesh, &self.value_id, [w.uv, w.normal, w.color].map(|w| w * diagonal2));
        // (A survivor keeps its flag: a seam vertex goes only into one on the same seam.)
        self.on_seam = seen.iter().map(|sets| sets[1] != NONE).collect();
        self.add_seam_planes(mesh);
        if self.options.lock_seams {
            for (vertex, &seam) in self.vertices.iter_mut().zip(&self.on_seam) {
                if seam && vertex.kind != VertexKind::Frozen {
                    vertex.kind = VertexKind::Anchored;
                }
            }
        }
    }

    /// Constraint planes along the seams, as along the borders: through each seam edge and
    /// perpendicular to each face beside it. A seam vertex moves only along its seam (rule 7), and
    /// with these a collapse along a seam that turns costs what it moves the seam by, so that a
    /// chart keeps its outline on the surface (without them a seam loop on a flat stretch, an
    /// eye's chart on the Duck, shrinks to a triangle for almost nothing and its texture spreads
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
                let spoke = match (self.on_seam[a as usize], self.on_seam[b as usize]) {
                    (true, true) => None,
                    (true, false) if anchor(a) => Some((a, k)),
                    (false, true) if anchor(b) => Some((b, (k + 1) % 3)),
                    _ => continue,
                };
                // The face across (a, b), and whether its corners at a and b carry other values.
                let across = self.fans[a as usize].iter().find(|d| d.face != f as u32 && d.touches(b));
                let Some(d) = across else { continue };
                let g = d.face;
                let same = self.same_values(3 * f as u32 + k as u32, self.source_at(g, a))
                    && self.same_values(3 * f as u32 + (k as u32 + 1) % 3, self.source_at(g, b));
                if same {
                    continue;
                }
                let weight = match (spoke, &mesh.corners.uvs) {
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

    /// Whether input corners `x` and `y`, of the same vertex, carry the same values.
    #[inline]
    pub(super) fn same_values(&self, x: u32, y: u32) -> bool {
        self.value_id[x as usize] == self.value_id[y as usize]
    }

    /// The input corner whose values vertex `v` has in face `f`.
    pub(super) fn source_at(&self, f: u32, v: u32) -> u32 {
        let k = self.triangles[f as usize].iter().position(|&x| x == v).expect("v is a corner of f");
        self.corner_source[3 * f as usize + k]
    }

    /// Rule 7 for collapsing `b` into `a` over the faces `dead` (one or two) of their edge: the
    /// values each of b's corners takes, as `(b's values, a's values)` pairs for the first and the
    /// second side; `None` when the collapse would carry values across a seam. With one set of
    /// values at b, both sides map it to a's values in the edge's faces, which must agree. With two
    /// (b on a seam) the edge must have two faces that differ at b, each side maps to a's values
    /// in its face, and those must differ too (a on the same seam). More than two: refused.
    pub(super) fn seam_sides(&self, a: u32, b: u32, dead: &[u32]) -> Option<[(u32, u32); 2]> {
        let same = |x: u32, y: u32| self.same_values(x, y);
        let b_first = self.source_at(dead[0], b);
        let a_first = self.source_at(dead[0], a);
        let mut b_other = NONE;
        // (A vertex off the seams has one set of values: nothing to look for.)
        let fan: &[Corner] = if self.on_seam[b as usize] { &self.fans[b as usize] } else { &[] };
        for corner in fan {
            let s = self.source_at(corner.face, b);
            if same(s, b_first) {
                continue;
            }
            if b_other == NONE {
                b_other = s;
            } else if !same(s, b_other) {
                return None;
            }
        }
        if b_other == NONE {
            // One set at b: a's values must be one across the edge's faces.
            if let Some(&second) = dead.get(1)
                && !same(self.source_at(second, a), a_first)
            {
                return None;
            }
            return Some([(b_first, a_first), (b_first, a_first)]);
        }
        let &[_, second] = dead else { return None };
        let (b_second, a_second) = (self.source_at(second, b), self.source_at(second, a));
        if same(b_second, b_first) || same(a_second, a_first) {
            return None;
        }
        Some([(b_first, a_first), (b_second, a_second)])
    }

    /// Rule 7 in texture space: every face that b keeps (not in `dead`), with b's texture
    /// coordinates replaced as `sides` says, keeps the orientation and a non-zero area of its
    /// texture-space triangle (a flipped one would show the texture mirrored). True without
    /// texture coordinates.
    pub(super) fn texture_keeps_orientation(&self, b: u32, dead: &[u32; 2], sides: [(u32, u32); 2]) -> bool {
        let Some(uv) = &self.attributes.uvs else { return true };
        let [(b_first, a_first), (_, a_second)] = sides;
        let area = |s: [u32; 3]| {
            let [p, q, r] = s.map(|k| uv[k as usize].map(f64::from));
            (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])
        };
        self.fans[b as usize].iter().filter(|c| c.face != dead[0] && c.face != dead[1]).all(|c| {
            let f = c.face as usize;
            let k = self.triangles[f].iter().position(|&x| x == b).expect("b is a corner of its faces");
            let mut sources = [0, 1, 2].map(|i| self.corner_source[3 * f + i]);
            let before = area(sources);
            let first = self.same_values(sources[k], b_first);
            sources[k] = if first { a_first } else { a_second };
            let after = area(sources);
            // A face without texture-space area has no orientation to keep.
            before == 0.0 || after * before > 0.0
        })
    }

    /// Brings `triangles` up to date after a run without tracking: every corner names the vertex
    /// its input vertex was merged into, last merge first (the same as renaming at each collapse).
    /// Built from the input's triangles (`mesh`, the one the state was made from): the state
    /// holds no copy while it does not track them.
    pub(crate) fn rebuild_triangles(&mut self, mesh: &Mesh, log: &[CollapseRecord]) {
        if self.track_triangles {
            return;
        }
        let mut last: Vec<u32> = (0..self.vertices.len() as u32).collect();
        for record in log.iter().rev() {
            last[record.removed as usize] = last[record.survivor as usize];
        }
        self.triangles = mesh.triangles.iter().map(|t| t.map(|v| last[v as usize])).collect();
        self.track_triangles = true;
    }

    /// The live vertices that never move: frozen (non-manifold) ones and anchors.
    pub(crate) fn frozen_vertices(&self) -> usize {
        (self.vertices.iter().zip(&self.vertex_alive))
            .filter(|&(v, &alive)| alive && matches!(v.kind, VertexKind::Frozen | VertexKind::Anchored))
            .count()
    }

    /// The surviving mesh: live vertices in input order, live faces in input order.
    pub(crate) fn output_mesh(&self) -> Mesh {
        let mut new_index = vec![NONE; self.vertices.len()];
        let mut positions = Vec::new();
        for (v, slot) in new_index.iter_mut().enumerate() {
            if self.vertex_alive[v] && !self.fans[v].is_empty() {
                *slot = positions.len() as u32;
                positions.push(self.vertices[v].position);
            }
        }
        let live = || (0..self.triangles.len()).filter(|&f| self.face_alive[f]);
        let triangles: Vec<[u32; 3]> = live().map(|f| self.triangles[f].map(|v| new_index[v as usize])).collect();
        let corners = if self.corner_source.is_empty() {
            CornerAttributes::default()
        } else {
            self.attributes.pick(live().flat_map(|f| (0..3).map(move |k| self.corner_source[3 * f + k] as usize)))
        };
        let mesh = Mesh { positions, triangles, corners };
        debug_assert!(mesh.check().is_ok());
        mesh
    }

    pub(crate) fn point(&self, v: u32) -> DVec3 {
        to_f64(self.vertices[v as usize].position)
    }

    pub(crate) fn face_normal(&self, f: u32) -> DVec3 {
        debug_assert!(self.track_triangles, "the triangle array is not being kept current");
        let [a, b, c] = self.triangles[f as usize];
        let (pa, pb, pc) = (self.point(a), self.point(b), self.point(c));
        (pb - pa).cross(pc - pa).normalize_or_zero()
    }

    /// Mean of the unit normals of the faces around `v` (Gouraud).
    pub(crate) fn fan_normal(&self, v: u32) -> DVec3 {
        let p = self.point(v);
        let sum: DVec3 = self.fans[v as usize]
            .iter()
            .map(|c| (self.point(c.next) - p).cross(self.point(c.prev) - p).normalize_or_zero())
            .sum();
        sum.normalize_or_zero()
    }

    /// Faces on edge (a, b), as corners of `a`'s fan, and how many there are.
    pub(super) fn edge_corners(&self, a: u32, b: u32) -> ([Corner; 2], usize) {
        self.fans[a as usize].touching(b)
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
            for corner in &self.fans[v as usize] {
                let x = corner.next;
                if x != other {
                    self.vertices[x as usize].prefetch();
                    self.fans[x as usize].prefetch();
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
            prefetch(&self.version[v]);
            self.vertices[v].prefetch();
            self.fans[v].prefetch();
        }
    }

    /// Applies a legal collapse and returns its log record.
    pub(crate) fn collapse(&mut self, legal: Legal) -> CollapseRecord {
        let scratch_is_current = legal.check == self.check_id;
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
        let mut dead = [NONE; 2];
        for (slot, corner) in dead.iter_mut().zip(&shared[..shared_count]) {
            let (f, third) = (corner.face, corner.other(b));
            // The face with half-edge a→b is the left face of the split (vs = a, vt = b).
            if corner.next == b {
                record.left = third;
                record.left_face = f;
            } else {
                record.right = third;
                record.right_face = f;
            }
            self.face_alive[f as usize] = false;
            *slot = f;
            let fan = &mut self.fans[third as usize];
            if let Some(i) = fan.find_face(f) {
                fan.remove(i);
            }
        }
        // Rule 7's mapping of b's values to a's (checked legal: `is_legal` refused it otherwise).
        let sides = if self.corner_source.is_empty() {
            None
        } else {
            let count = if dead[1] == NONE { 1 } else { 2 };
            let sides = self.seam_sides(a, b, &dead[..count]).expect("rule 7 was checked");
            self.merge_wedges(sides);
            Some(sides)
        };
        let is_dead = |d: &Corner| (d.face == dead[0]) | (d.face == dead[1]);
        self.fans[a as usize].retain(|d| !is_dead(d));
        let moved = std::mem::take(&mut self.fans[b as usize]);
        let count_a = self.fans[a as usize].len() as f64;
        // b's fan holds each face at b once, the shared faces among them.
        let count_b = moved.len() - shared_count;
        debug_assert_eq!(count_b, moved.iter().filter(|d| !is_dead(d)).count());
        for corner in moved.iter().filter(|d| !is_dead(d)) {
            let f = corner.face;
            if self.track_triangles {
                for (k, slot) in self.triangles[f as usize].iter_mut().enumerate() {
                    if *slot == b {
                        *slot = a;
                        if let Some([(b_first, a_first), (_, a_second)]) = sides {
                            let at = 3 * f as usize + k;
                            let first =
                                self.value_id[self.corner_source[at] as usize] == self.value_id[b_first as usize];
                            if self.options.record_progressive {
                                self.journal.push((f, self.corner_source[at]));
                            }
                            self.corner_source[at] = if first { a_first } else { a_second };
                        }
                    }
                }
            }
            // The face's corners at its two other vertices name b: they now name a.
            for x in [corner.next, corner.prev] {
                let fan = &mut self.fans[x as usize];
                if let Some(d) = fan.find_face(f).map(|i| &mut fan[i]) {
                    // One of the two names b: which one is as good as random, so no branch.
                    d.next = if d.next == b { a } else { d.next };
                    d.prev = if d.prev == b { a } else { d.prev };
                }
            }
            self.fans[a as usize].push(*corner);
        }
        self.vertex_alive[b as usize] = false;
        if legal.hole != NONE {
            // The hole closed: the merged vertex's fan and the hole's third corner's are closed now
            // (the caller ranks the corner's edges again: their class changed).
            self.vertices[a as usize].kind = VertexKind::Interior;
            self.vertices[legal.hole as usize].kind = VertexKind::Interior;
            self.version[legal.hole as usize] = self.version[legal.hole as usize].wrapping_add(1);
        }
        let removed = self.vertices[b as usize];
        let survivor = &mut self.vertices[a as usize];
        survivor.position = c.position;
        survivor.quadric += removed.quadric;
        // The linear estimate, unless it cancels out (opposite normals): then Gouraud on the new fan.
        let linear = (survivor.normal * count_a + removed.normal * count_b as f64).normalize_or_zero();
        self.vertices[a as usize].normal = match self.options.normals {
            NormalUpdate::Linear if linear != DVec3::ZERO => linear,
            NormalUpdate::Linear | NormalUpdate::Recompute => self.fan_normal(a),
        };
        self.update_cones(a, scratch_is_current);
        self.update_guard(a, b);
        self.version[a as usize] = self.version[a as usize].wrapping_add(1);
        self.version[b as usize] = self.version[b as usize].wrapping_add(1);
        if sides.is_some() && self.options.record_progressive {
            self.journal_ends.push(self.journal.len() as u32);
        }
        record
    }

    /// A fresh stamp for the scratch marks (every mark is older).
    pub(super) fn next_stamp(&mut self) -> u32 {
        self.mark_stamp = self.mark_stamp.wrapping_add(2);
        if self.mark_stamp < 2 {
            self.mark.iter_mut().for_each(|m| *m = 0);
            self.mark_stamp = 2;
        }
        self.mark_stamp
    }

    /// The one-ring of `v`, sorted, into `out`.
    pub(crate) fn neighbours(&self, v: u32, out: &mut Vec<u32>) {
        // Around a closed manifold fan every neighbour is the `next` corner of exactly one face, so
        // those alone are the ring; an open fan adds its last `prev`. Sorting the `next` corners
        // and adding only the missing `prev` ones sorts half as much as sorting both.
        let fan = &self.fans[v as usize];
        out.clear();
        out.extend(fan.iter().map(|c| c.next));
        out.sort_unstable();
        out.dedup();
        let nexts = out.len();
        for c in fan {
            let missing = if nexts <= 16 {
                !out[..nexts].contains(&c.prev)
            } else {
                out[..nexts].binary_search(&c.prev).is_err()
            };
            if missing {
                out.push(c.prev);
            }
        }
        if out.len() > nexts {
            out.sort_unstable();
            out.dedup();
        }
    }

    /// Corners of face `f` (kept current only for a state made with [`State::new`]).
    pub(crate) fn triangle(&self, f: u32) -> [u32; 3] {
        debug_assert!(self.track_triangles, "the triangle array is not being kept current");
        self.triangles[f as usize]
    }

    /// Whether face `f` is still in the mesh.
    pub(crate) fn is_face_alive(&self, f: u32) -> bool {
        self.face_alive[f as usize]
    }

    /// Whether vertex `v` is still in the mesh.
    pub(crate) fn is_vertex_alive(&self, v: u32) -> bool {
        self.vertex_alive[v as usize]
    }

    /// The class of vertex `v`, fixed at the start.
    pub(crate) fn kind(&self, v: u32) -> VertexKind {
        self.vertices[v as usize].kind
    }

    /// The live faces around vertex `v`.
    pub(crate) fn faces_around(&self, v: u32) -> impl Iterator<Item = u32> + '_ {
        self.fans[v as usize].iter().map(|c| c.face)
    }
}
