//! Bounding-volume hierarchy over a mesh's triangles for closest-point queries.
//!
//! Binary tree of axis-aligned boxes, built top-down by splitting at the median centroid along the
//! box's longest axis (O(n log n), no SAH: for nearest-point queries on surface meshes the median
//! split is within a few percent of SAH and builds faster). Queries descend the nearer child first
//! and prune boxes farther than the best distance found so far; a caller can seed that bound with
//! a hint (the previous sample's triangle), which makes coherent query streams cheap.

use glam::DVec3;

use crate::mesh::Mesh;

const LEAF_SIZE: usize = 4;

/// Boxes and corners are kept in `f32`, as the mesh stores its positions: every value is one of
/// those positions' coordinates (or their min or max), so widening to `f64` at use gives exactly
/// the numbers an `f64` copy would hold, in half the memory.
#[derive(Debug, Clone, Copy)]
struct Node {
    min: [f32; 3],
    max: [f32; 3],
    /// Leaf: first triangle slot; inner: index of the right child (left child is `self + 1`).
    start_or_right: u32,
    /// Leaf: number of triangles; inner: 0.
    count: u32,
}

/// A triangle while the tree is built: its centroid (the split key), box and face.
#[derive(Debug, Clone, Copy)]
struct Item {
    centroid: [f64; 3],
    min: [f32; 3],
    max: [f32; 3],
    face: u32,
}

/// Closest-point acceleration structure over a mesh's (non-degenerate-index) triangles.
#[derive(Debug, Clone)]
pub struct TriangleBvh {
    nodes: Vec<Node>,
    /// Triangle corners in leaf order.
    corners: Vec<[[f32; 3]; 3]>,
    /// Original face index of each slot.
    faces: Vec<u32>,
}

/// Result of a closest-point query.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClosestPoint {
    /// Squared distance to the closest point.
    pub distance_squared: f64,
    /// The closest point.
    pub point: DVec3,
    /// Slot of the triangle in the BVH (pass back as a hint).
    pub slot: u32,
}

impl ClosestPoint {
    /// Euclidean distance.
    pub fn distance(&self) -> f64 {
        self.distance_squared.sqrt()
    }

    /// Original face index.
    pub fn face(&self, bvh: &TriangleBvh) -> u32 {
        bvh.faces[self.slot as usize]
    }
}

impl TriangleBvh {
    /// Builds the tree; `None` if the mesh has no faces.
    pub fn new(mesh: &Mesh) -> Option<TriangleBvh> {
        if mesh.triangles.is_empty() {
            return None;
        }
        // Each triangle's box and centroid once, so that building reads them in sequence rather
        // than gathering every triangle's corners again at every level.
        let mut items: Vec<Item> = (0..mesh.face_count())
            .map(|f| {
                let corners = mesh.triangles[f].map(|v| mesh.positions[v as usize]);
                let [a, b, c] = corners.map(widen);
                let min = [0, 1, 2].map(|k| corners[0][k].min(corners[1][k]).min(corners[2][k]));
                let max = [0, 1, 2].map(|k| corners[0][k].max(corners[1][k]).max(corners[2][k]));
                Item { centroid: ((a + b + c) / 3.0).to_array(), min, max, face: f as u32 }
            })
            .collect();
        let mut bvh = TriangleBvh {
            nodes: Vec::with_capacity(2 * items.len() / LEAF_SIZE + 1),
            corners: Vec::with_capacity(items.len()),
            faces: Vec::with_capacity(items.len()),
        };
        bvh.build(mesh, &mut items);
        Some(bvh)
    }

    fn build(&mut self, mesh: &Mesh, items: &mut [Item]) -> u32 {
        let mut min = [f32::INFINITY; 3];
        let mut max = [f32::NEG_INFINITY; 3];
        for item in items.iter() {
            for k in 0..3 {
                min[k] = min[k].min(item.min[k]);
                max[k] = max[k].max(item.max[k]);
            }
        }
        let index = self.nodes.len() as u32;
        if items.len() <= LEAF_SIZE {
            let start = self.corners.len() as u32;
            for item in items.iter() {
                self.corners.push(mesh.triangles[item.face as usize].map(|v| mesh.positions[v as usize]));
                self.faces.push(item.face);
            }
            self.nodes.push(Node { min, max, start_or_right: start, count: items.len() as u32 });
            return index;
        }
        self.nodes.push(Node { min, max, start_or_right: 0, count: 0 });
        let axis = (widen(max) - widen(min)).max_position();
        let mid = items.len() / 2;
        items.select_nth_unstable_by(mid, |a, b| a.centroid[axis].total_cmp(&b.centroid[axis]));
        let (left, right) = items.split_at_mut(mid);
        self.build(mesh, left);
        let right_index = self.build(mesh, right);
        self.nodes[index as usize].start_or_right = right_index;
        index
    }

    /// Number of triangles indexed.
    pub fn len(&self) -> usize {
        self.faces.len()
    }

    /// Whether the tree is empty (never true for a built tree).
    pub fn is_empty(&self) -> bool {
        self.faces.is_empty()
    }

    /// Squared distance from `query` to the triangle in `slot` (infinite for a slot out of range).
    #[inline]
    pub fn slot_distance_squared(&self, query: DVec3, slot: u32) -> f64 {
        match self.corners.get(slot as usize) {
            Some(&[a, b, c]) => {
                (closest_point_on_triangle(query, widen(a), widen(b), widen(c)) - query).length_squared()
            }
            None => f64::INFINITY,
        }
    }

    /// The original face index of the triangle in `slot`.
    #[inline]
    pub fn slot_face(&self, slot: u32) -> u32 {
        self.faces[slot as usize]
    }

    /// The corners of the triangle in `slot`, widened to f64.
    #[inline]
    pub fn slot_corners(&self, slot: u32) -> [DVec3; 3] {
        self.corners[slot as usize].map(widen)
    }

    /// Appends to `out` the slots whose triangle's bounding box meets the box `[min, max]` and
    /// the slab `{x : |normal · x − offset| ≤ half}` (`normal` of unit length); stops and returns
    /// false once `out` holds more than `limit` slots.
    pub fn slots_in_box(
        &self,
        min: DVec3,
        max: DVec3,
        slab: (DVec3, f64, f64),
        limit: usize,
        out: &mut Vec<u32>,
    ) -> bool {
        let mut stack: [u32; 64] = [0; 64];
        let mut depth = 1;
        let (normal, offset, half) = slab;
        let overlaps = |lo: [f32; 3], hi: [f32; 3]| {
            let (lo, hi) = (widen(lo), widen(hi));
            // A box meets the slab when its projection on the normal does.
            let (center, extent) = ((lo + hi) * 0.5, (hi - lo) * 0.5);
            lo.cmple(max).all()
                && hi.cmpge(min).all()
                && (normal.dot(center) - offset).abs() <= half + extent.dot(normal.abs())
        };
        while depth > 0 {
            depth -= 1;
            let index = stack[depth];
            let node = self.nodes[index as usize];
            if !overlaps(node.min, node.max) {
                continue;
            }
            if node.count > 0 {
                let start = node.start_or_right as usize;
                for slot in start..start + node.count as usize {
                    let [a, b, c] = self.corners[slot];
                    let lo = [0, 1, 2].map(|k| a[k].min(b[k]).min(c[k]));
                    let hi = [0, 1, 2].map(|k| a[k].max(b[k]).max(c[k]));
                    if overlaps(lo, hi) {
                        out.push(slot as u32);
                        if out.len() > limit {
                            return false;
                        }
                    }
                }
                continue;
            }
            stack[depth] = node.start_or_right;
            stack[depth + 1] = index + 1;
            depth += 2;
        }
        true
    }

    /// The slot of each face of the mesh the tree was built from (`u32::MAX` for a face left out),
    /// for use as hints.
    pub fn slots_by_face(&self, faces: usize) -> Vec<u32> {
        let mut slots = vec![u32::MAX; faces];
        for (slot, &f) in self.faces.iter().enumerate() {
            if let Some(s) = slots.get_mut(f as usize) {
                *s = slot as u32;
            }
        }
        slots
    }

    /// Closest point on the surface to `query`. `hint` is a slot from an earlier result whose
    /// triangle is probably close; it only affects speed, never the answer.
    pub fn closest_point(&self, query: DVec3, hint: Option<u32>) -> ClosestPoint {
        let mut best = ClosestPoint { distance_squared: f64::INFINITY, point: DVec3::ZERO, slot: 0 };
        if let Some(slot) = hint.filter(|&s| (s as usize) < self.corners.len()) {
            let [a, b, c] = self.corners[slot as usize].map(widen);
            let p = closest_point_on_triangle(query, a, b, c);
            best = ClosestPoint { distance_squared: (p - query).length_squared(), point: p, slot };
        }
        // Each entry carries its box's distance, computed when it was pushed: a node is searched
        // only if that is still below the best distance when it is popped.
        let root = self.nodes[0];
        let mut stack: [(u32, f64); 64] = [(0, 0.0); 64];
        stack[0] = (0, box_distance_squared(query, root.min, root.max));
        let mut depth = 1;
        while depth > 0 {
            depth -= 1;
            let (index, distance) = stack[depth];
            if distance >= best.distance_squared {
                continue;
            }
            let node = self.nodes[index as usize];
            if node.count > 0 {
                let start = node.start_or_right as usize;
                for slot in start..start + node.count as usize {
                    let [a, b, c] = self.corners[slot].map(widen);
                    let p = closest_point_on_triangle(query, a, b, c);
                    let d = (p - query).length_squared();
                    if d < best.distance_squared {
                        best = ClosestPoint { distance_squared: d, point: p, slot: slot as u32 };
                    }
                }
                continue;
            }
            let left = index + 1;
            let right = node.start_or_right;
            let dl = {
                let n = self.nodes[left as usize];
                box_distance_squared(query, n.min, n.max)
            };
            let dr = {
                let n = self.nodes[right as usize];
                box_distance_squared(query, n.min, n.max)
            };
            // Push the farther child first so the nearer one is searched first. The median split
            // keeps the depth at ~log2(n / LEAF_SIZE), far below the stack size.
            let (near, far) = if dl <= dr { ((left, dl), (right, dr)) } else { ((right, dr), (left, dl)) };
            if far.1 < best.distance_squared {
                stack[depth] = far;
                depth += 1;
            }
            if near.1 < best.distance_squared {
                stack[depth] = near;
                depth += 1;
            }
        }
        best
    }
}

#[inline]
fn widen(p: [f32; 3]) -> DVec3 {
    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

#[inline]
fn box_distance_squared(p: DVec3, min: [f32; 3], max: [f32; 3]) -> f64 {
    let (min, max) = (widen(min), widen(max));
    let d = (min - p).max(p - max).max(DVec3::ZERO);
    d.length_squared()
}

/// Closest point on triangle `abc` to `p` (Ericson, Real-Time Collision Detection, §5.1.5).
/// Handles degenerate (zero-area) triangles by falling through to edges and vertices.
pub fn closest_point_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return a + ab * v;
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return a + ac * w;
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return b + (c - b) * w;
    }
    let denom = va + vb + vc;
    if denom <= 0.0 || !denom.is_finite() {
        // Degenerate triangle: the closest of its three edges.
        let on = |s: DVec3, e: DVec3| {
            let d = e - s;
            let len2 = d.length_squared();
            let t = if len2 > 0.0 { ((p - s).dot(d) / len2).clamp(0.0, 1.0) } else { 0.0 };
            s + d * t
        };
        return [on(a, b), on(b, c), on(c, a)]
            .into_iter()
            .min_by(|x, y| (*x - p).length_squared().total_cmp(&(*y - p).length_squared()))
            .expect("three candidates");
    }
    let v = vb / denom;
    let w = vc / denom;
    a + ab * v + ac * w
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::procedural;
    use crate::rng::SplitMix64;

    #[test]
    fn bvh_matches_brute_force() {
        let mesh = procedural::bumpy_blob(20, 30, 3);
        let bvh = TriangleBvh::new(&mesh).unwrap();
        let mut rng = SplitMix64::new(7);
        let mut hint = None;
        for _ in 0..500 {
            let q = DVec3::new(rng.next_f64() * 3.0 - 1.5, rng.next_f64() * 3.0 - 1.5, rng.next_f64() * 3.0 - 1.5);
            let brute = (0..mesh.face_count())
                .map(|f| {
                    let [a, b, c] = mesh.triangle_points(f);
                    (closest_point_on_triangle(q, a, b, c) - q).length_squared()
                })
                .fold(f64::INFINITY, f64::min);
            let got = bvh.closest_point(q, hint);
            hint = Some(got.slot);
            assert!(
                (got.distance_squared - brute).abs() <= 1e-12 * brute.max(1.0),
                "{} vs {brute}",
                got.distance_squared
            );
        }
    }

    #[test]
    fn closest_point_regions() {
        let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
        let inside = closest_point_on_triangle(DVec3::new(0.2, 0.2, 1.0), a, b, c);
        assert!((inside - DVec3::new(0.2, 0.2, 0.0)).length() < 1e-15);
        assert_eq!(closest_point_on_triangle(DVec3::new(-1.0, -1.0, 0.0), a, b, c), a);
        assert_eq!(closest_point_on_triangle(DVec3::new(0.5, -1.0, 0.0), a, b, c), DVec3::new(0.5, 0.0, 0.0));
        // Degenerate (collinear) triangle.
        let q = closest_point_on_triangle(DVec3::new(0.5, 1.0, 0.0), a, b, DVec3::new(2.0, 0.0, 0.0));
        assert!((q - DVec3::new(0.5, 0.0, 0.0)).length() < 1e-12);
    }
}
