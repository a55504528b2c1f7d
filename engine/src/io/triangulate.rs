//! Polygon triangulation for faces with more than three corners, in work bounded by the corner
//! count whatever the polygon.
//!
//! In the plane of the polygon's Newell normal: a polygon of at most 64 corners is clipped ear by
//! ear from its start (as meshlod always has, so meshes read before keep their triangles); a larger
//! convex polygon (every turn the same way, one winding) is fanned, O(n). Any other is ear-clipped over a linked list, each candidate ear tested
//! only against the reflex corners whose z-order (Morton) code lies between those of its bounding
//! box's corners (only a reflex corner can lie inside an ear), as earcut does. The tests are counted against a budget linear in n; a polygon that uses it up
//! (self-intersecting, degenerate, or built to be slow) has its rest fanned from one corner, which is
//! what most readers do for every polygon. So a polygon of n corners costs O(n) memory and at most
//! about [`WORK_PER_CORNER`] · n steps.

use glam::{DVec2, DVec3};

/// Point-in-triangle tests and grid cells visited per corner before the rest is fanned.
pub(crate) const WORK_PER_CORNER: usize = 256;

/// Sets `local` to the triangles (as corner numbers) that cover the face whose corners sit at
/// `corners`: a triangle as it is, a polygon by [`triangulate_polygon`] (`points` is scratch).
pub(crate) fn triangulate_face(
    corners: impl ExactSizeIterator<Item = [f32; 3]>,
    points: &mut Vec<DVec3>,
    local: &mut Vec<[usize; 3]>,
) {
    local.clear();
    if corners.len() == 3 {
        local.push([0, 1, 2]);
    } else {
        points.clear();
        points.extend(corners.map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)));
        triangulate_polygon(points, local);
    }
}

/// Appends triangles (as positions into `points`) that cover the polygon.
pub(crate) fn triangulate_polygon(points: &[DVec3], out: &mut Vec<[usize; 3]>) {
    let n = points.len();
    if n < 3 {
        return;
    }
    if n == 3 {
        out.push([0, 1, 2]);
        return;
    }
    // Newell's normal is robust for non-planar and concave polygons.
    let mut normal = DVec3::ZERO;
    for i in 0..n {
        let (a, b) = (points[i], points[(i + 1) % n]);
        normal += DVec3::new((a.y - b.y) * (a.z + b.z), (a.z - b.z) * (a.x + b.x), (a.x - b.x) * (a.y + b.y));
    }
    // Zero, or NaN from a non-finite corner: no plane to clip in.
    if normal.length_squared().is_nan() || normal.length_squared() <= 0.0 {
        fan(0..n, out);
        return;
    }
    let normal = normal.normalize();
    let u = normal.any_orthonormal_vector();
    let v = normal.cross(u);
    let flat: Vec<DVec2> = points.iter().map(|p| DVec2::new(p.dot(u), p.dot(v))).collect();
    if n <= SMALL_POLYGON {
        clip_small(&flat, out);
    } else if is_convex(&flat) {
        fan(0..n, out);
    } else {
        EarClipper::new(&flat).run(out);
    }
}

/// Polygons up to this many corners (every one a modelling tool writes, in practice) are clipped
/// by [`clip_small`], whose triangles every mesh read so far was made of.
const SMALL_POLYGON: usize = 64;

/// Ear clipping that takes the first ear from the start of the remaining corners each time:
/// O(n³) but at most [`SMALL_POLYGON`] corners; if no ear is found (a self-intersecting or
/// degenerate polygon) the rest is fanned.
fn clip_small(flat: &[DVec2], out: &mut Vec<[usize; 3]>) {
    let mut remaining: Vec<usize> = (0..flat.len()).collect();
    while remaining.len() > 3 {
        let m = remaining.len();
        let ear = (0..m).find(|&i| {
            let (a, b, c) = (remaining[(i + m - 1) % m], remaining[i], remaining[(i + 1) % m]);
            is_small_ear(flat, [a, b, c], &remaining)
        });
        match ear {
            Some(i) => {
                out.push([remaining[(i + m - 1) % m], remaining[i], remaining[(i + 1) % m]]);
                remaining.remove(i);
            }
            None => break,
        }
    }
    fan(remaining.into_iter(), out);
}

fn is_small_ear(flat: &[DVec2], [a, b, c]: [usize; 3], remaining: &[usize]) -> bool {
    let (pa, pb, pc) = (flat[a], flat[b], flat[c]);
    if cross(pa, pb, pc) <= 0.0 {
        return false; // reflex or degenerate corner
    }
    remaining.iter().filter(|&&i| i != a && i != b && i != c).all(|&i| !in_triangle(pa, pb, pc, flat[i]))
}

/// Triangles (c₀, cᵢ, cᵢ₊₁) over the corners in order.
fn fan(corners: impl Iterator<Item = usize>, out: &mut Vec<[usize; 3]>) {
    let corners: Vec<usize> = corners.collect();
    for i in 1..corners.len().saturating_sub(1) {
        out.push([corners[0], corners[i], corners[i + 1]]);
    }
}

fn cross(o: DVec2, a: DVec2, b: DVec2) -> f64 {
    (a - o).perp_dot(b - o)
}

/// Whether `p` lies inside the counter-clockwise triangle (a, b, c) or on its border.
fn in_triangle(a: DVec2, b: DVec2, c: DVec2, p: DVec2) -> bool {
    cross(a, b, p) >= 0.0 && cross(b, c, p) >= 0.0 && cross(c, a, p) >= 0.0
}

/// Whether every corner turns left (the Newell normal makes the polygon counter-clockwise) and the
/// edge directions go around once: a convex polygon, which a fan covers exactly.
fn is_convex(flat: &[DVec2]) -> bool {
    let n = flat.len();
    let mut turned = 0.0;
    for i in 0..n {
        let (a, b, c) = (flat[(i + n - 1) % n], flat[i], flat[(i + 1) % n]);
        if cross(a, b, c) <= 0.0 {
            return false;
        }
        turned += (b - a).angle_to(c - b);
    }
    (turned - std::f64::consts::TAU).abs() < 1e-6
}

const NONE: usize = usize::MAX;

/// Ear clipping over a doubly linked list of the remaining corners, with the reflex corners sorted
/// by z-order code.
struct EarClipper<'a> {
    flat: &'a [DVec2],
    prev: Vec<usize>,
    next: Vec<usize>,
    reflex: Vec<bool>,
    /// (z-order code, corner) of every corner reflex at the start, sorted (corners that stop being
    /// reflex are skipped when read).
    by_z: Vec<(u32, usize)>,
    min: DVec2,
    scale: DVec2,
    work: usize,
    budget: usize,
}

/// Spreads the low 16 bits of `x` to the even bits.
fn spread(x: u32) -> u32 {
    let mut x = x & 0xffff;
    x = (x | (x << 8)) & 0x00ff_00ff;
    x = (x | (x << 4)) & 0x0f0f_0f0f;
    x = (x | (x << 2)) & 0x3333_3333;
    (x | (x << 1)) & 0x5555_5555
}

impl<'a> EarClipper<'a> {
    fn new(flat: &'a [DVec2]) -> EarClipper<'a> {
        let n = flat.len();
        let prev = (0..n).map(|i| (i + n - 1) % n).collect();
        let next = (0..n).map(|i| (i + 1) % n).collect();
        let (mut min, mut max) = (flat[0], flat[0]);
        for &p in flat {
            min = min.min(p);
            max = max.max(p);
        }
        let scale = DVec2::splat(65535.0) / (max - min).max(DVec2::splat(f64::MIN_POSITIVE));
        let mut clipper = EarClipper {
            flat,
            prev,
            next,
            reflex: vec![false; n],
            by_z: Vec::new(),
            min,
            scale,
            work: 0,
            budget: WORK_PER_CORNER * n + 1024,
        };
        for (i, &p) in flat.iter().enumerate() {
            if clipper.turn(i) <= 0.0 {
                clipper.reflex[i] = true;
                clipper.by_z.push((clipper.z(p), i));
            }
        }
        clipper.by_z.sort_unstable();
        clipper
    }

    fn turn(&self, b: usize) -> f64 {
        cross(self.flat[self.prev[b]], self.flat[b], self.flat[self.next[b]])
    }

    /// The z-order code of a point of the polygon's bounding box.
    fn z(&self, p: DVec2) -> u32 {
        let q = ((p - self.min) * self.scale).clamp(DVec2::ZERO, DVec2::splat(65535.0));
        spread(q.x as u32) | (spread(q.y as u32) << 1)
    }

    /// Whether corner `b` with its neighbours is an ear: a left turn with no reflex corner inside.
    fn is_ear(&mut self, b: usize) -> bool {
        let (a, c) = (self.prev[b], self.next[b]);
        let (pa, pb, pc) = (self.flat[a], self.flat[b], self.flat[c]);
        if cross(pa, pb, pc) <= 0.0 {
            return false;
        }
        let (lo, hi) = (pa.min(pb).min(pc), pa.max(pb).max(pc));
        // Every point of the box has a code between those of its corners.
        let (z_lo, z_hi) = (self.z(lo), self.z(hi));
        let first = self.by_z.partition_point(|&(z, _)| z < z_lo);
        for &(z, i) in &self.by_z[first..] {
            if z > z_hi {
                break;
            }
            self.work += 1;
            if i == a || i == b || i == c || !self.reflex[i] {
                continue;
            }
            let p = self.flat[i];
            if p.cmpge(lo).all() && p.cmple(hi).all() && in_triangle(pa, pb, pc, p) {
                return false;
            }
        }
        true
    }

    fn run(mut self, out: &mut Vec<[usize; 3]>) {
        let mut remaining = self.flat.len();
        let mut node = 0;
        // The corner where a full pass without an ear would end.
        let mut stop = self.prev[node];
        while remaining > 3 && self.work < self.budget {
            if self.is_ear(node) {
                let (a, c) = (self.prev[node], self.next[node]);
                out.push([a, node, c]);
                self.next[a] = c;
                self.prev[c] = a;
                self.prev[node] = NONE;
                remaining -= 1;
                // A clipped ear can only make its neighbours turn further left.
                for x in [a, c] {
                    if self.reflex[x] && self.turn(x) > 0.0 {
                        self.reflex[x] = false;
                    }
                }
                // On past the new corner, so that clipping goes around the polygon (as earcut
                // does) rather than fanning ever larger triangles from one corner.
                node = self.next[c];
                stop = c;
                continue;
            }
            if node == stop {
                break; // a whole pass without an ear: not a simple polygon
            }
            node = self.next[node];
        }
        // What is left (three corners, or a rest no ear was found in) is fanned.
        let start = node;
        let mut rest = vec![start];
        let mut x = self.next[start];
        while x != start && rest.len() < remaining {
            rest.push(x);
            x = self.next[x];
        }
        fan(rest.into_iter(), out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat_points(xy: &[(f64, f64)]) -> Vec<DVec3> {
        xy.iter().map(|&(x, y)| DVec3::new(x, y, 0.0)).collect()
    }

    fn area_and_orientation(pts: &[DVec3], tris: &[[usize; 3]]) -> (f64, bool) {
        let mut area = 0.0;
        let mut positive = true;
        for t in tris {
            let z = 0.5 * (pts[t[1]] - pts[t[0]]).cross(pts[t[2]] - pts[t[0]]).z;
            area += z;
            positive &= z > 0.0;
        }
        (area, positive)
    }

    #[test]
    fn concave_polygon_is_clipped_inside() {
        // An L shape: fanning from corner 0 would put a triangle outside the polygon.
        let pts = flat_points(&[(0., 0.), (2., 0.), (2., 1.), (1., 1.), (1., 2.), (0., 2.)]);
        let mut tris = Vec::new();
        triangulate_polygon(&pts, &mut tris);
        assert_eq!(tris.len(), 4);
        let (area, positive) = area_and_orientation(&pts, &tris);
        assert!((area - 3.0).abs() < 1e-12, "area {area}");
        assert!(positive, "{tris:?}");
    }

    #[test]
    fn large_polygons_cost_linear_work() {
        // A convex 20 000-gon (fanned) and a star of 20 000 corners, half of them reflex (clipped
        // within the budget): n − 2 triangles each, covering the polygon exactly.
        let n = 20_000;
        let circle: Vec<(f64, f64)> = (0..n)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / n as f64;
                (a.cos(), a.sin())
            })
            .collect();
        let star: Vec<(f64, f64)> = circle
            .iter()
            .enumerate()
            .map(|(i, &(x, y))| if i % 2 == 0 { (x, y) } else { (0.9 * x, 0.9 * y) })
            .collect();
        for (name, shape) in [("circle", circle), ("star", star)] {
            let pts = flat_points(&shape);
            let polygon_area: f64 = (0..n).map(|i| pts[i].truncate().perp_dot(pts[(i + 1) % n].truncate()) * 0.5).sum();
            let mut tris = Vec::new();
            triangulate_polygon(&pts, &mut tris);
            assert_eq!(tris.len(), n - 2, "{name}");
            let (area, positive) = area_and_orientation(&pts, &tris);
            assert!(positive, "{name}: a flipped or degenerate triangle");
            assert!((area - polygon_area).abs() < 1e-9 * polygon_area, "{name}: {area} vs {polygon_area}");
        }
    }

    #[test]
    fn self_intersecting_and_degenerate_polygons_end() {
        // A random walk (crossing itself everywhere) and a polygon repeating its corners: the budget
        // ends the clipping, the rest is fanned; n − 2 triangles, no hang.
        let mut rng = crate::rng::SplitMix64::new(5);
        let n = 50_000;
        let walk: Vec<(f64, f64)> = (0..n).map(|_| (rng.next_f64(), rng.next_f64())).collect();
        let repeated: Vec<(f64, f64)> = (0..n).map(|i| [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)][i % 3]).collect();
        for shape in [walk, repeated] {
            let mut tris = Vec::new();
            triangulate_polygon(&flat_points(&shape), &mut tris);
            assert_eq!(tris.len(), n - 2);
            assert!(tris.iter().flatten().all(|&i| i < n));
        }
    }
}
