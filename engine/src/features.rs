//! Shape features and model inputs for the parameter predictor.
//!
//! This file is the one contract on feature order: the `meshlod samples` CSV header is written
//! from these name lists, the training code reads the names from that header and stores them in
//! the model metadata, and the predictor checks the metadata against these lists when it loads.
//!
//! The paper's network sees only (original faces, target faces, ratio); the shape features say
//! why two meshes with the same counts want different w: how curved and how sharp they are, how
//! uneven their sampling is, how much border they have.

use glam::DVec3;

use crate::mesh::Mesh;
use crate::topology::Topology;

/// How many shape features there are.
pub const SHAPE_FEATURES: usize = 8;

/// The shape features of one mesh, in the order of [`SHAPE_FEATURE_NAMES`].
pub type Shape = [f32; SHAPE_FEATURES];

/// Names of [`shape_features`], in order.
pub const SHAPE_FEATURE_NAMES: [&str; SHAPE_FEATURES] = [
    "dihedral_mean",
    "dihedral_std",
    "sharp_edge_share",
    "edge_length_cv",
    "boundary_edge_share",
    "normal_variation",
    "area_cv",
    "irregular_vertex_share",
];

/// Names of the w classifier's inputs ([`w_input`]), in order: counts and ratio, then the shape.
pub const W_INPUT_NAMES: [&str; SHAPE_FEATURES + 3] =
    join(["log10_faces_in", "log10_faces_target", "ratio"], SHAPE_FEATURE_NAMES);

/// Names of the ETC regressor's inputs ([`etc_input`]), in order: the shape, then the mode and size.
pub const ETC_INPUT_NAMES: [&str; SHAPE_FEATURES + 2] = join(SHAPE_FEATURE_NAMES, ["subdivide", "log2_face_ratio"]);

/// `head` followed by `tail`, so the input-name lists are built from [`SHAPE_FEATURE_NAMES`] and
/// cannot drift from it.
const fn join<const A: usize, const B: usize, const N: usize>(
    head: [&'static str; A],
    tail: [&'static str; B],
) -> [&'static str; N] {
    assert!(A + B == N, "the joined length is the sum of the parts");
    let mut out = [""; N];
    let mut i = 0;
    while i < A {
        out[i] = head[i];
        i += 1;
    }
    while i < N {
        out[i] = tail[i - A];
        i += 1;
    }
    out
}

/// The classes of w the paper's network chooses from.
pub const W_CLASSES: [f64; 5] = [0.0, 0.5, 1.0, 1.5, 2.0];

/// An edge counts as sharp when its faces' normals differ by more than this (degrees).
pub const SHARP_EDGE_DEGREES: f64 = 30.0;

fn mean_and_cv(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut n, mut sum, mut sum2) = (0.0, 0.0, 0.0);
    for v in values {
        n += 1.0;
        sum += v;
        sum2 += v * v;
    }
    if n == 0.0 {
        return (0.0, 0.0);
    }
    let mean = sum / n;
    let var = (sum2 / n - mean * mean).max(0.0);
    (mean, if mean > 0.0 { var.sqrt() / mean } else { 0.0 })
}

/// The shape features of a mesh, in the order of [`SHAPE_FEATURE_NAMES`]. Scale-invariant.
pub fn shape_features(mesh: &Mesh) -> Shape {
    let topology = Topology::new(mesh);
    let normals: Vec<DVec3> = (0..mesh.face_count()).map(|f| mesh.face_area_vector(f).normalize_or_zero()).collect();
    let cos_sharp = SHARP_EDGE_DEGREES.to_radians().cos();
    let mut bends = Vec::new();
    let mut sharp = 0usize;
    let mut boundary = 0usize;
    for e in 0..topology.edges.len() {
        let faces = topology.edge_faces.get(e);
        match faces.len() {
            1 => boundary += 1,
            2 => {
                let cos = normals[faces[0].index()].dot(normals[faces[1].index()]).clamp(-1.0, 1.0);
                bends.push(1.0 - cos);
                sharp += (cos < cos_sharp) as usize;
            }
            _ => {}
        }
    }
    let (bend_mean, bend_cv) = mean_and_cv(bends.iter().copied());
    let edges = topology.edges.len().max(1) as f64;
    let (_, length_cv) = mean_and_cv(topology.edges.iter().map(|&[a, b]| (mesh.point(a) - mesh.point(b)).length()));
    let (_, area_cv) = mean_and_cv((0..mesh.face_count()).map(|f| mesh.face_area(f)));
    let mut variation = Vec::new();
    let mut irregular = 0usize;
    let mut interior = 0usize;
    let mut on_boundary = vec![false; mesh.vertex_count()];
    for (e, &[a, b]) in topology.edges.iter().enumerate() {
        if topology.edge_faces.get(e).len() == 1 {
            on_boundary[a as usize] = true;
            on_boundary[b as usize] = true;
        }
    }
    for (v, &is_boundary) in on_boundary.iter().enumerate() {
        let faces = topology.vertex_faces.get(v);
        if faces.is_empty() {
            continue;
        }
        let sum: DVec3 = faces.iter().map(|f| normals[f.index()]).sum();
        variation.push(1.0 - sum.length() / faces.len() as f64);
        if !is_boundary {
            interior += 1;
            irregular += (faces.len() != 6) as usize;
        }
    }
    let (variation_mean, _) = mean_and_cv(variation.into_iter());
    [
        bend_mean as f32,
        (bend_mean * bend_cv) as f32,
        (sharp as f64 / edges) as f32,
        length_cv as f32,
        (boundary as f64 / edges) as f32,
        variation_mean as f32,
        area_cv as f32,
        (irregular as f64 / interior.max(1) as f64) as f32,
    ]
}

/// The w classifier's input for simplifying `faces_in` faces to `target_faces`.
pub fn w_input(shape: &Shape, faces_in: usize, target_faces: usize) -> [f32; SHAPE_FEATURES + 3] {
    let faces_in = faces_in.max(1) as f64;
    let target = target_faces.max(1) as f64;
    let mut x = [0f32; SHAPE_FEATURES + 3];
    x[0] = faces_in.log10() as f32;
    x[1] = target.log10() as f32;
    x[2] = (1.0 - target / faces_in) as f32;
    x[3..].copy_from_slice(shape);
    x
}

/// The ETC regressor's input for reaching `target_faces` from `faces_in` by subdividing or
/// simplifying.
pub fn etc_input(shape: &Shape, subdivide: bool, faces_in: usize, target_faces: usize) -> [f32; SHAPE_FEATURES + 2] {
    let mut x = [0f32; SHAPE_FEATURES + 2];
    x[..SHAPE_FEATURES].copy_from_slice(shape);
    x[SHAPE_FEATURES] = if subdivide { 1.0 } else { 0.0 };
    x[SHAPE_FEATURES + 1] = (target_faces.max(1) as f64 / faces_in.max(1) as f64).log2() as f32;
    x
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::procedural;

    #[test]
    fn names_and_inputs_agree() {
        assert_eq!(&W_INPUT_NAMES[3..], &SHAPE_FEATURE_NAMES[..]);
        assert_eq!(&ETC_INPUT_NAMES[..SHAPE_FEATURES], &SHAPE_FEATURE_NAMES[..]);
    }

    #[test]
    fn features_tell_shapes_apart_and_ignore_scale() {
        let cube = shape_features(&procedural::sharp_box(6));
        let sphere = shape_features(&procedural::icosphere(3));
        let terrain = shape_features(&procedural::terrain(16, 2));
        // A box has sharp edges; a fine sphere has none; the terrain has a border.
        assert!(cube[2] > 0.05 && sphere[2] == 0.0, "{cube:?} {sphere:?}");
        assert!(terrain[4] > 0.0 && sphere[4] == 0.0);
        let scaled = procedural::icosphere(3);
        let scaled =
            Mesh::new(scaled.positions.iter().map(|p| p.map(|c| c * 40.0)).collect(), scaled.triangles).unwrap();
        let s2 = shape_features(&scaled);
        for (a, b) in sphere.iter().zip(&s2) {
            assert!((a - b).abs() < 1e-4, "{sphere:?} vs {s2:?}");
        }
        let x = w_input(&sphere, 1000, 100);
        assert!((x[2] - 0.9).abs() < 1e-6 && (x[0] - 3.0).abs() < 1e-6);
    }
}
