//! Polygon triangulation for faces with more than three corners.
//!
//! Ear clipping in the plane of the polygon's Newell normal: correct for convex and simple concave
//! polygons (OBJ quads and n-gons from modelling tools). If no ear can be found (self-intersecting
//! or degenerate polygon) the rest is fanned from its first corner, which is what most readers do
//! for every polygon.

use glam::{DVec2, DVec3};

/// Appends triangles (as positions into `corners`) that cover the polygon.
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
    if normal.length_squared() == 0.0 {
        fan(&(0..n).collect::<Vec<_>>(), out);
        return;
    }
    let normal = normal.normalize();
    let u = normal.any_orthonormal_vector();
    let v = normal.cross(u);
    let flat: Vec<DVec2> = points.iter().map(|p| DVec2::new(p.dot(u), p.dot(v))).collect();

    let mut remaining: Vec<usize> = (0..n).collect();
    while remaining.len() > 3 {
        let m = remaining.len();
        let ear = (0..m).find(|&i| {
            let (a, b, c) = (remaining[(i + m - 1) % m], remaining[i], remaining[(i + 1) % m]);
            is_ear(&flat, a, b, c, &remaining)
        });
        match ear {
            Some(i) => {
                out.push([remaining[(i + m - 1) % m], remaining[i], remaining[(i + 1) % m]]);
                remaining.remove(i);
            }
            None => break,
        }
    }
    fan(&remaining, out);
}

fn fan(corners: &[usize], out: &mut Vec<[usize; 3]>) {
    for i in 1..corners.len().saturating_sub(1) {
        out.push([corners[0], corners[i], corners[i + 1]]);
    }
}

fn cross(o: DVec2, a: DVec2, b: DVec2) -> f64 {
    (a - o).perp_dot(b - o)
}

fn is_ear(flat: &[DVec2], a: usize, b: usize, c: usize, remaining: &[usize]) -> bool {
    let (pa, pb, pc) = (flat[a], flat[b], flat[c]);
    if cross(pa, pb, pc) <= 0.0 {
        return false; // reflex or degenerate corner
    }
    remaining.iter().filter(|&&i| i != a && i != b && i != c).all(|&i| {
        let p = flat[i];
        !(cross(pa, pb, p) >= 0.0 && cross(pb, pc, p) >= 0.0 && cross(pc, pa, p) >= 0.0)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn concave_polygon_is_clipped_inside() {
        // An L shape: fanning from corner 0 would put a triangle outside the polygon.
        let pts: Vec<DVec3> = [(0., 0.), (2., 0.), (2., 1.), (1., 1.), (1., 2.), (0., 2.)]
            .iter()
            .map(|&(x, y)| DVec3::new(x, y, 0.0))
            .collect();
        let mut tris = Vec::new();
        triangulate_polygon(&pts, &mut tris);
        assert_eq!(tris.len(), 4);
        let area: f64 = tris.iter().map(|t| 0.5 * (pts[t[1]] - pts[t[0]]).cross(pts[t[2]] - pts[t[0]]).z).sum();
        assert!((area - 3.0).abs() < 1e-12, "area {area}");
        for t in &tris {
            let z = (pts[t[1]] - pts[t[0]]).cross(pts[t[2]] - pts[t[0]]).z;
            assert!(z > 0.0, "triangle {t:?} is flipped or degenerate");
        }
    }
}
