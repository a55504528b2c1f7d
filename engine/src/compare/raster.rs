//! A small deterministic software rasteriser: orthographic views of a mesh spread over the sphere
//! around a bounding sphere, a z-buffer, and per pixel the face that is seen and where on it.

use glam::DVec3;

use crate::mesh::Mesh;

/// An orthographic view: the camera looks along `-direction` at the frame's centre, `right` and
/// `up` span the image plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct View {
    pub direction: DVec3,
    right: DVec3,
    up: DVec3,
}

impl View {
    /// `n` directions spread evenly over the sphere (a Fibonacci lattice), the same for every run.
    pub fn spread(n: usize) -> Vec<View> {
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        (0..n)
            .map(|i| {
                let y = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
                let r = (1.0 - y * y).max(0.0).sqrt();
                let phi = golden * i as f64;
                View::along(DVec3::new(r * phi.cos(), y, r * phi.sin()))
            })
            .collect()
    }

    /// The view from `direction` (towards the viewer), with up as near world Y as it can be.
    pub fn along(direction: DVec3) -> View {
        let direction = direction.normalize();
        let reference = if direction.y.abs() > 0.99 { DVec3::Z } else { DVec3::Y };
        let right = reference.cross(direction).normalize();
        let up = direction.cross(right);
        View { direction, right, up }
    }
}

/// Where the views look: a centre and a radius that the image's half-width spans.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Frame {
    pub centre: DVec3,
    pub radius: f64,
}

impl Frame {
    /// The bounding sphere of `mesh`'s surface (its box's centre, half its diagonal); `None` for a
    /// mesh without faces or of no extent.
    pub fn around(mesh: &Mesh) -> Option<Frame> {
        let bounds = mesh.surface_bounds()?;
        let radius = 0.5 * bounds.diagonal();
        (radius > 0.0 && radius.is_finite()).then(|| Frame { centre: bounds.center(), radius })
    }
}

/// What a view of a mesh sees at each pixel (row by row from the top): the face nearest the
/// viewer, and the barycentric weights of the point there, or nothing.
#[derive(Debug, Clone)]
pub(crate) struct Coverage {
    /// Per pixel: the face seen ([`crate::mesh::NONE`] for none).
    pub face: Vec<u32>,
    /// Per pixel: the weights of the face's three corners at the pixel's centre.
    pub weights: Vec<[f32; 3]>,
}

/// Rasterises `mesh` seen from `view` in `frame` on a `size` × `size` grid: both sides of every
/// face are drawn, the nearest wins (the first face drawn on a tie, so the result depends on
/// nothing but the input).
pub(crate) fn rasterise(mesh: &Mesh, frame: &Frame, view: &View, size: usize) -> Coverage {
    let n = size * size;
    let mut out = Coverage { face: vec![crate::mesh::NONE; n], weights: vec![[0.0; 3]; n] };
    let mut depth = vec![f64::NEG_INFINITY; n];
    let scale = 0.5 * size as f64 / frame.radius;
    let half = 0.5 * size as f64;
    let project = |v: u32| {
        let q = mesh.point(v) - frame.centre;
        [half + q.dot(view.right) * scale, half - q.dot(view.up) * scale, q.dot(view.direction)]
    };
    let screen: Vec<[f64; 3]> = (0..mesh.vertex_count() as u32).map(project).collect();
    let edge = |a: &[f64; 3], b: &[f64; 3], p: [f64; 2]| (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
    for (f, t) in mesh.triangles.iter().enumerate() {
        let [a, b, c] = t.map(|v| screen[v as usize]);
        let area = edge(&a, &b, [c[0], c[1]]);
        if area.abs() < 1e-12 {
            continue;
        }
        let (x0, x1) = span(a[0].min(b[0]).min(c[0]), a[0].max(b[0]).max(c[0]), size);
        let (y0, y1) = span(a[1].min(b[1]).min(c[1]), a[1].max(b[1]).max(c[1]), size);
        for y in y0..y1 {
            for x in x0..x1 {
                let p = [x as f64 + 0.5, y as f64 + 0.5];
                let w = [edge(&b, &c, p) / area, edge(&c, &a, p) / area, edge(&a, &b, p) / area];
                if w.iter().any(|&w| w < 0.0) {
                    continue;
                }
                let z = w[0] * a[2] + w[1] * b[2] + w[2] * c[2];
                let k = y * size + x;
                if z > depth[k] {
                    depth[k] = z;
                    out.face[k] = f as u32;
                    out.weights[k] = w.map(|w| w as f32);
                }
            }
        }
    }
    out
}

/// The pixel columns (or rows) whose centres may lie in `[lo, hi]`, within the image.
fn span(lo: f64, hi: f64, size: usize) -> (usize, usize) {
    let first = (lo - 0.5).ceil().max(0.0);
    let last = (hi - 0.5).floor() + 1.0;
    if !(first.is_finite() && last.is_finite()) || last <= first {
        return (0, 0);
    }
    (first.min(size as f64) as usize, last.min(size as f64) as usize)
}
