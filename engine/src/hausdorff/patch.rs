//! The patch bound: an upper bound of max over a piece T of d(·, B) from a whole patch of B's
//! triangles at once, for pieces that no single triangle of B covers (a coarse triangle over a
//! fine surface, or a piece straddling an edge of B in a flat region).
//!
//! Project along T's normal n. If the projections of a set S of B's triangles cover T's
//! projection, every point p of T has a point q on some t in S with the same projection, so
//! d(p, B) ≤ |p − q| = |height of q above T's plane|. Height is affine over t, so it is at most
//! t's largest vertex height, and at most the largest height of t's plane over T's corners. Hence
//! max over T of d(·, B) ≤ max over t in S of the smaller of the two.
//!
//! Coverage of T by the union of the projected triangles is proved without building the union:
//! (1) each corner of T lies in some projected triangle of S; (2) no edge of T meets an edge of S
//! that only one triangle of S uses (the union's boundary); (3) no such boundary vertex lies
//! inside T. By (1) and (2) T's boundary stays inside the union; by (3) no hole of the union lies
//! inside T. Touching or collinear edges count as meeting, so doubt makes the test fail, never
//! pass.

use glam::{DVec2, DVec3};

use crate::bvh::TriangleBvh;

/// Most triangles the box query may return before the bound is not tried.
const MAX_QUERY: usize = 1024;

/// Scratch buffers reused across pieces of one worker.
#[derive(Default)]
pub(crate) struct Scratch {
    slots: Vec<u32>,
    kept: Vec<[DVec2; 3]>,
    edges: Vec<Edge>,
    /// A parent's query result, shared by its children (see [`Scratch::query`]).
    pub(crate) shared: Vec<u32>,
}

/// A vertex by its position's bits: triangles that share a position share the vertex, so an
/// unwelded seam is not taken for a boundary.
type Key = [u32; 3];

/// A kept triangle's edge: a hash of its two vertices (for sorting), the vertices themselves
/// (to tell hash collisions apart) and its projected end points.
type Edge = (u64, Key, Key, DVec2, DVec2);

#[inline]
fn mix(k: Key) -> u64 {
    let mut h = (k[0] as u64) ^ ((k[1] as u64) << 32) ^ (k[2] as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    h ^= h >> 33;
    h = h.wrapping_mul(0xFF51_AFD7_ED55_8CCD);
    h ^ (h >> 33)
}

#[inline]
fn key(p: DVec3) -> Key {
    // Corners are f32 positions widened to f64: narrowing gives them back exactly.
    [p.x as f32, p.y as f32, p.z as f32].map(f32::to_bits)
}

#[inline]
fn cross(o: DVec2, a: DVec2, b: DVec2) -> f64 {
    (a - o).perp_dot(b - o)
}

/// Whether closed segments ab and cd meet (touching and collinear overlap included).
fn segments_meet(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> bool {
    if a.max(b).cmplt(c.min(d)).any() || c.max(d).cmplt(a.min(b)).any() {
        return false;
    }
    let (d1, d2) = (cross(a, b, c), cross(a, b, d));
    let (d3, d4) = (cross(c, d, a), cross(c, d, b));
    !((d1 > 0.0 && d2 > 0.0) || (d1 < 0.0 && d2 < 0.0) || (d3 > 0.0 && d4 > 0.0) || (d3 < 0.0 && d4 < 0.0))
}

/// Whether p lies in the counter-clockwise triangle abc, boundary included.
#[inline]
fn in_triangle(p: DVec2, [a, b, c]: [DVec2; 3]) -> bool {
    cross(a, b, p) >= 0.0 && cross(b, c, p) >= 0.0 && cross(c, a, p) >= 0.0
}

/// Whether an edge of the counter-clockwise triangle `a` has all of `b` strictly outside it.
#[inline]
fn separated(a: &[DVec2; 3], b: &[DVec2; 3]) -> bool {
    (0..3).any(|k| b.iter().all(|&p| cross(a[k], a[(k + 1) % 3], p) < 0.0))
}

/// Whether p lies strictly inside the counter-clockwise triangle abc.
#[inline]
fn strictly_in_triangle(p: DVec2, [a, b, c]: [DVec2; 3]) -> bool {
    cross(a, b, p) > 0.0 && cross(b, c, p) > 0.0 && cross(c, a, p) > 0.0
}

/// Largest |height| of the affine function with `heights` at the corners of the projected triangle
/// `t` (counter-clockwise, twice its area `area`) over the part of `t` inside the counter-clockwise
/// triangle `piece`: |affine| is convex, so that is reached at a corner of the overlap polygon
/// (`t` clipped by the piece's three edge lines). Infinite when the overlap comes out empty (a
/// touch, lost to rounding): the caller's other bounds stand then.
fn overlap_height(piece: &[DVec2; 3], t: &[DVec2; 3], heights: &[f64; 3], area: f64) -> f64 {
    // At most 3 + 3 corners after three clips.
    let mut polygon = [DVec2::ZERO; 9];
    let mut clipped = [DVec2::ZERO; 9];
    polygon[..3].copy_from_slice(t);
    let mut count = 3;
    for k in 0..3 {
        let (a, b) = (piece[k], piece[(k + 1) % 3]);
        let side = |p: DVec2| cross(a, b, p);
        let mut kept = 0;
        for i in 0..count {
            let (p, q) = (polygon[i], polygon[(i + 1) % count]);
            let (sp, sq) = (side(p), side(q));
            if sp >= 0.0 {
                clipped[kept] = p;
                kept += 1;
            }
            if (sp >= 0.0) != (sq >= 0.0) && kept < clipped.len() {
                clipped[kept] = p + (q - p) * (sp / (sp - sq));
                kept += 1;
            }
        }
        count = kept.min(polygon.len());
        polygon[..count].copy_from_slice(&clipped[..count]);
        if count == 0 {
            return f64::INFINITY;
        }
    }
    polygon[..count].iter().fold(0f64, |m, &x| {
        let w = [cross(t[1], t[2], x), cross(t[2], t[0], x), cross(t[0], t[1], x)];
        m.max(((w[0] * heights[0] + w[1] * heights[1] + w[2] * heights[2]) / area).abs())
    })
}

/// The unit normal of a piece, if it has area.
fn unit_normal([c0, c1, c2]: &[DVec3; 3]) -> Option<DVec3> {
    let normal = (*c1 - *c0).cross(*c2 - *c0);
    let length = normal.length();
    (length > 0.0).then(|| normal / length)
}

/// Finds into `out` the slots of B that can matter to the patch bound of the piece with `corners`
/// at `limit`, or to any part of it at a lower limit (a part has the same plane and a smaller
/// prism). False when there are too many, or the piece has no area.
pub(crate) fn query(bvh: &TriangleBvh, corners: &[DVec3; 3], limit: f64, out: &mut Vec<u32>) -> bool {
    out.clear();
    let Some(n) = unit_normal(corners).filter(|_| limit.is_finite()) else { return false };
    let [c0, c1, c2] = *corners;
    // Only triangles within `limit` of T's plane over T's footprint matter: the box of the prism
    // T ± limit · n holds every one whose projection meets T's.
    let lift = (n * limit).abs();
    let (lo, hi) = (c0.min(c1).min(c2) - lift, c0.max(c1).max(c2) + lift);
    bvh.slots_in_box(lo, hi, (n, n.dot(c0), limit), MAX_QUERY, out)
}

/// The patch bound of the piece with `corners`, using B's triangles whose heights above the
/// piece's plane are all below `limit` (a bound already known); `None` when coverage is not proved.
/// `candidates`: the result of [`query`] for this piece or a piece containing it with a limit at
/// least `limit`; `None` to query here.
pub(crate) fn patch_bound(
    bvh: &TriangleBvh,
    corners: &[DVec3; 3],
    limit: f64,
    candidates: Option<&[u32]>,
    scratch: &mut Scratch,
) -> Option<f64> {
    let [c0, c1, _] = *corners;
    let n = unit_normal(corners).filter(|_| limit.is_finite())?;
    let e1 = (c1 - c0).normalize();
    let e2 = n.cross(e1);
    let flat = |p: DVec3| {
        let r = p - c0;
        DVec2::new(r.dot(e1), r.dot(e2))
    };
    let t2 = [DVec2::ZERO, flat(c1), flat(corners[2])];
    let (lo, hi) = (t2[0].min(t2[1]).min(t2[2]), t2[0].max(t2[1]).max(t2[2]));

    let mut own = std::mem::take(&mut scratch.slots);
    let slots = match candidates {
        Some(c) => c,
        None => {
            if !query(bvh, corners, limit, &mut own) {
                scratch.slots = own;
                return None;
            }
            &own[..]
        }
    };
    scratch.kept.clear();
    scratch.edges.clear();
    let mut bound = 0f64;
    for &slot in slots {
        let q = bvh.slot_corners(slot);
        let heights = q.map(|p| (p - c0).dot(n));
        let p2 = q.map(flat);
        if p2[0].min(p2[1]).min(p2[2]).cmpgt(hi).any() || p2[0].max(p2[1]).max(p2[2]).cmplt(lo).any() {
            continue;
        }
        // Folded (seen from behind) or edge-on triangles are left out: the union of the rest is
        // then smaller, which can only make the coverage test fail.
        let area = cross(p2[0], p2[1], p2[2]);
        if area.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            continue;
        }
        // Triangles whose projection does not meet T's (an edge of either separates them) are
        // left out too: their edges cannot meet T, so leaving them out changes no verdict, but
        // their heights would loosen the bound.
        if separated(&t2, &p2) || separated(&p2, &t2) {
            continue;
        }
        // Over its own projection t's height is at most its largest vertex height; and, being
        // affine, at most its plane's largest height over T's corners (|affine| is convex on T).
        let at_vertices = heights.iter().fold(0f64, |m, h| m.max(h.abs()));
        let at_corners = t2.iter().fold(0f64, |m, &x| {
            let w = [cross(p2[1], p2[2], x), cross(p2[2], p2[0], x), cross(p2[0], p2[1], x)];
            m.max(((w[0] * heights[0] + w[1] * heights[1] + w[2] * heights[2]) / area).abs())
        });
        // Tighter still, its height over the overlap of the two projections; computed only when
        // the cheaper bounds would raise the largest so far or drop the triangle, since otherwise
        // it changes neither the bound nor what is kept.
        let mut height = at_vertices.min(at_corners);
        if height > bound.max(0.0) || height >= limit {
            height = height.min(overlap_height(&t2, &p2, &heights, area));
        }
        if height.partial_cmp(&limit) != Some(std::cmp::Ordering::Less) {
            continue;
        }
        bound = bound.max(height);
        scratch.kept.push(p2);
        let v = q.map(key);
        for k in 0..3 {
            let (a, b) = (v[k], v[(k + 1) % 3]);
            let (a, b) = (a.min(b), a.max(b));
            scratch.edges.push((mix(a) ^ mix(b).rotate_left(17), a, b, p2[k], p2[(k + 1) % 3]));
        }
    }
    scratch.slots = own;
    covered(&t2, scratch).then_some(bound)
}

/// Whether the kept triangles' projections (`scratch.kept`, their edges `scratch.edges`) cover
/// T's, `t2`: (1) every corner of T lies in some kept triangle, and no boundary edge of the kept
/// set (2) crosses an edge of T or (3) has an end strictly inside T.
fn covered(t2: &[DVec2; 3], scratch: &mut Scratch) -> bool {
    // (1) Every corner of T in some kept triangle.
    if !t2.iter().all(|&p| scratch.kept.iter().any(|&t| in_triangle(p, t))) {
        return false;
    }
    // Boundary edges: used by one kept triangle only.
    scratch.edges.sort_unstable_by_key(|e| e.0);
    let edges = &scratch.edges;
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j].0 == edges[i].0 {
            j += 1;
        }
        // Within a run of equal hashes, an edge is a boundary edge when no other has its vertices.
        for e in &edges[i..j] {
            let shared = edges[i..j].iter().filter(|f| (f.1, f.2) == (e.1, e.2)).count() > 1;
            // (2) and (3).
            if !shared
                && ((0..3).any(|k| segments_meet(t2[k], t2[(k + 1) % 3], e.3, e.4))
                    || strictly_in_triangle(e.3, *t2)
                    || strictly_in_triangle(e.4, *t2))
            {
                return false;
            }
        }
        i = j;
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Mesh;
    use crate::procedural;

    fn plane_grid(n: u32, z: f32) -> Mesh {
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for i in 0..=n {
            for j in 0..=n {
                positions.push([i as f32 / n as f32, j as f32 / n as f32, z]);
            }
        }
        for i in 0..n {
            for j in 0..n {
                let v = |a: u32, b: u32| a * (n + 1) + b;
                triangles.push([v(i, j), v(i + 1, j), v(i + 1, j + 1)]);
                triangles.push([v(i, j), v(i + 1, j + 1), v(i, j + 1)]);
            }
        }
        Mesh::new(positions, triangles).unwrap()
    }

    #[test]
    fn a_coarse_triangle_over_a_fine_parallel_grid_is_bounded_by_the_offset() {
        let fine = plane_grid(10, 0.0);
        let bvh = TriangleBvh::new(&fine).unwrap();
        let piece = [DVec3::new(0.1, 0.1, 0.25), DVec3::new(0.9, 0.15, 0.25), DVec3::new(0.4, 0.85, 0.25)];
        let bound = patch_bound(&bvh, &piece, 0.5, None, &mut Scratch::default()).unwrap();
        assert!((bound - 0.25).abs() < 1e-7, "{bound}");
        // Reaching past the grid's border: not covered.
        let outside = [DVec3::new(0.5, 0.5, 0.25), DVec3::new(1.2, 0.5, 0.25), DVec3::new(0.5, 0.9, 0.25)];
        assert_eq!(patch_bound(&bvh, &outside, 0.5, None, &mut Scratch::default()), None);
    }

    #[test]
    fn the_bound_over_a_curved_surface_is_the_height_over_the_piece_itself() {
        // z = x² on a 40 × 40 grid over [−1, 1]²; a piece in the plane z = −0.1, below it. Triangles along the
        // piece's border reach beyond it, where the surface is farther: only their part over the
        // piece may count. The height over the piece, x² + 0.1, is convex: largest at a corner
        // (plus the grid's chord error, below 0.05² / 4).
        let mut grid = plane_grid(40, 0.0);
        for p in &mut grid.positions {
            let (x, y) = (p[0] * 2.0 - 1.0, p[1] * 2.0 - 1.0);
            *p = [x, y, x * x];
        }
        let bvh = TriangleBvh::new(&grid).unwrap();
        let corners = [DVec3::new(-0.45, -0.4, -0.1), DVec3::new(0.5, -0.3, -0.1), DVec3::new(0.05, 0.45, -0.1)];
        let bound = patch_bound(&bvh, &corners, 1.0, None, &mut Scratch::default()).unwrap();
        let exact = corners.iter().map(|c| c.x * c.x + 0.1).fold(0f64, f64::max);
        assert!(bound >= exact - 1e-9 && bound <= exact + 0.05f64.powi(2) / 4.0 + 1e-6, "{bound} vs {exact}");
    }

    #[test]
    fn a_hole_inside_the_piece_defeats_coverage() {
        let mut grid = plane_grid(10, 0.0);
        // Remove the two triangles of one cell in the middle of the piece.
        grid.triangles.retain(|t| !(t.contains(&(5 * 11 + 5)) && t.contains(&(6 * 11 + 6))));
        let bvh = TriangleBvh::new(&grid).unwrap();
        let piece = [DVec3::new(0.2, 0.2, 0.1), DVec3::new(0.9, 0.3, 0.1), DVec3::new(0.3, 0.9, 0.1)];
        assert_eq!(patch_bound(&bvh, &piece, 0.5, None, &mut Scratch::default()), None);
    }

    #[test]
    fn the_bound_holds_at_every_sampled_point() {
        // A piece above a bumpy surface: wherever the patch bound is proved, no point of the piece
        // is farther from the surface than it says.
        let surface = procedural::terrain(24, 5);
        let bvh = TriangleBvh::new(&surface).unwrap();
        let mut rng = crate::rng::SplitMix64::new(11);
        let mut proved = 0;
        for _ in 0..200 {
            let mut r = || rng.next_f64() * 1.2 - 0.6;
            let base = DVec3::new(r(), r(), 0.3 + 0.3 * r());
            let corners =
                [base, base + DVec3::new(0.3, 0.05 * r(), 0.1 * r()), base + DVec3::new(0.1 * r(), 0.3, 0.1 * r())];
            let Some(bound) = patch_bound(&bvh, &corners, 0.8, None, &mut Scratch::default()) else { continue };
            proved += 1;
            for i in 0..=10 {
                for j in 0..=10 - i {
                    let (u, v) = (i as f64 / 10.0, j as f64 / 10.0);
                    let p = corners[0] + (corners[1] - corners[0]) * u + (corners[2] - corners[0]) * v;
                    let d = bvh.closest_point(p, None).distance();
                    assert!(d <= bound + 1e-12, "{d} > {bound}");
                }
            }
        }
        assert!(proved > 100, "only {proved} of 200 pieces proved");
    }
}
