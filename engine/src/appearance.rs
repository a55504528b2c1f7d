//! How far a level of detail's texture coordinates and normals are from the input's: for points
//! spread over the LOD by area, the distance in texture space between the LOD's interpolated
//! texture coordinates and the input's at the nearest input point on the same chart, and the angle
//! between their interpolated normals at the nearest input point.
//!
//! A chart is a piece of the input whose faces join along edges with the same texture coordinates
//! on both sides. A LOD face belongs to the chart(s) its three corners' values come from (a
//! simplifier that keeps values, as meshlod and meshoptimizer do, takes them from the input's
//! corners; where its corners have no chart in common, or a value the input never had, the face
//! is compared with every chart). So a sample on a garment's outer layer is compared with that
//! layer, not with the lining a hair's breadth beneath it. Where the nearest input point lies on a
//! seam (or a hard edge), the input has two values there; every input triangle as near as the
//! nearest (to a relative 1e-9 of the bounding-box diagonal) is a candidate and the closest value
//! counts, so a sample is compared with its own side. Sampling is deterministic for a seed.

use glam::{DVec2, DVec3};

use crate::bvh::{TriangleBvh, closest_point_on_triangle};
use crate::mesh::Mesh;
use crate::rng::SplitMix64;

/// The distribution of one kind of error over the samples.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Spread {
    /// Area-weighted mean.
    pub mean: f64,
    /// 95th percentile.
    pub p95: f64,
    /// Largest at a sample (a lower bound of the maximum).
    pub max_sampled: f64,
}

/// Texture-space and normal error of a LOD against its input.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct AppearanceError {
    /// Points sampled on the LOD.
    pub samples: usize,
    /// Texture-space distance in texels of a square texture of the given size, against the
    /// nearest point of the sample's own chart (both meshes need texture coordinates).
    pub uv_texels: Option<Spread>,
    /// The same against the nearest input point of any chart: it also sees a chart that spread
    /// over its neighbours' place (an eye's texture over the cheek), and it also charges a
    /// sample the layer beneath it (a lining's values under a garment).
    pub uv_texels_any_chart: Option<Spread>,
    /// Angle between the normals, degrees (both meshes need normals).
    pub normal_degrees: Option<Spread>,
    /// LOD faces whose texture-space triangle turns the other way than the input's at the nearest
    /// point of the face's own chart (probed at the face's centroid): a texture drawn mirrored
    /// there. Faces without a chart or without texture-space area are not counted.
    pub uv_turned_over: Option<usize>,
}

fn spread(mut values: Vec<f64>) -> Option<Spread> {
    if values.is_empty() {
        return None;
    }
    let mean = values.iter().sum::<f64>() / values.len() as f64;
    values.sort_by(f64::total_cmp);
    let p95 = values[((values.len() - 1) as f64 * 0.95).round() as usize];
    Some(Spread { mean, p95, max_sampled: values[values.len() - 1] })
}

/// Barycentric coordinates of `p` projected onto the plane of triangle `t`; `None` for a
/// degenerate triangle.
pub(crate) fn barycentric(p: DVec3, [a, b, c]: [DVec3; 3]) -> Option<[f64; 3]> {
    let (v0, v1, v2) = (b - a, c - a, p - a);
    let (d00, d01, d11, d20, d21) = (v0.dot(v0), v0.dot(v1), v1.dot(v1), v2.dot(v0), v2.dot(v1));
    let denominator = d00 * d11 - d01 * d01;
    if denominator.abs() < f64::MIN_POSITIVE {
        return None;
    }
    let v = (d11 * d20 - d01 * d21) / denominator;
    let w = (d00 * d21 - d01 * d20) / denominator;
    Some([1.0 - v - w, v, w])
}

fn uv_at(mesh: &Mesh, f: usize, b: [f64; 3]) -> Option<DVec2> {
    let uvs = mesh.corners.uvs()?;
    Some((0..3).map(|k| DVec2::new(uvs[3 * f + k][0] as f64, uvs[3 * f + k][1] as f64) * b[k]).sum())
}

fn normal_at(mesh: &Mesh, f: usize, b: [f64; 3]) -> Option<DVec3> {
    let normals = mesh.corners.normals()?;
    Some((0..3).map(|k| DVec3::from(normals[3 * f + k].map(f64::from)) * b[k]).sum::<DVec3>().normalize_or_zero())
}

/// The error of `lod`'s texture coordinates and normals against `input`'s, at `samples` points
/// spread over `lod` by area (seeded by `seed`); texture-space distances in texels of a
/// `texture_size`² texture. `None` when either mesh has no faces or no area.
pub fn appearance_error(
    input: &Mesh,
    lod: &Mesh,
    samples: usize,
    texture_size: f64,
    seed: u64,
) -> Option<AppearanceError> {
    let bvh = TriangleBvh::new(input)?;
    let diagonal = input.bounds()?.diagonal();
    let areas: Vec<f64> = (0..lod.face_count()).map(|f| lod.face_area(f)).collect();
    let total: f64 = areas.iter().sum();
    if total <= 0.0 || samples == 0 {
        return None;
    }
    let mut cumulative = Vec::with_capacity(areas.len());
    let mut running = 0.0;
    for a in &areas {
        running += a;
        cumulative.push(running);
    }
    let with_uv = input.corners.uvs().is_some() && lod.corners.uvs().is_some();
    let with_normal = input.corners.normals().is_some() && lod.corners.normals().is_some();
    let charts = if with_uv { Charts::new(input) } else { None };
    let mut rng = SplitMix64::new(seed);
    let (mut uv_errors, mut uv_any_errors, mut normal_errors) = (Vec::new(), Vec::new(), Vec::new());
    let mut candidates = Vec::new();
    let mut hint = None;
    for _ in 0..samples {
        let pick = rng.next_f64() * total;
        let f = cumulative.partition_point(|&c| c < pick).min(areas.len() - 1);
        let (r1, r2) = (rng.next_f64().sqrt(), rng.next_f64());
        let b = [1.0 - r1, r1 * (1.0 - r2), r1 * r2];
        let corners = lod.triangle_points(f);
        let p: DVec3 = (0..3).map(|k| corners[k] * b[k]).sum();
        let nearest = bvh.closest_point(p, hint);
        hint = Some(nearest.slot);
        let radius = nearest.distance() + 1e-9 * diagonal;
        candidates.clear();
        let reach = DVec3::splat(radius);
        bvh.slots_in_box(p - reach, p + reach, (DVec3::X, p.x, radius), 64, &mut candidates);
        if candidates.is_empty() {
            candidates.push(nearest.slot);
        }
        let (mut best_uv, mut best_normal) = (f64::INFINITY, f64::INFINITY);
        let (uv_out, normal_out) = (uv_at(lod, f, b), normal_at(lod, f, b));
        for &slot in &candidates {
            let t = bvh.slot_corners(slot);
            let q = closest_point_on_triangle(p, t[0], t[1], t[2]);
            if (q - p).length() > radius && slot != nearest.slot {
                continue;
            }
            let g = bvh.slot_face(slot) as usize;
            let bq = barycentric(q, t).unwrap_or([1.0, 0.0, 0.0]);
            if let (Some(out), Some(inp)) = (uv_out, uv_at(input, g, bq)) {
                best_uv = best_uv.min((out - inp).length() * texture_size);
            }
            if let (Some(out), Some(inp)) = (normal_out, normal_at(input, g, bq)) {
                best_normal = best_normal.min(out.dot(inp).clamp(-1.0, 1.0).acos().to_degrees());
            }
        }
        if with_uv && best_uv.is_finite() {
            uv_any_errors.push(best_uv);
        }
        // On the face's own chart(s), when it has one: the nearest point there instead.
        if let (Some(charts), Some(out)) = (&charts, uv_out)
            && let Some(own) = charts.of_face(lod, f)
        {
            let d = charts.nearest_uv_distance(input, &own, p, out);
            if d.is_finite() {
                best_uv = d * texture_size;
            }
        }
        if with_uv && best_uv.is_finite() {
            uv_errors.push(best_uv);
        }
        if with_normal && best_normal.is_finite() {
            normal_errors.push(best_normal);
        }
    }
    let uv_turned_over = charts.as_ref().map(|charts| {
        (0..lod.face_count())
            .filter(|&f| {
                let Some(own) = charts.of_face(lod, f) else { return false };
                let centroid = lod.triangle_points(f).iter().sum::<DVec3>() / 3.0;
                charts.nearest(&own, centroid).is_some_and(|(g, _)| uv_area(lod, f) * uv_area(input, g) < 0.0)
            })
            .count()
    });
    Some(AppearanceError {
        samples,
        uv_texels: spread(uv_errors),
        uv_texels_any_chart: spread(uv_any_errors),
        normal_degrees: spread(normal_errors),
        uv_turned_over,
    })
}

/// Twice the signed area of face `f`'s texture-space triangle (0 without texture coordinates).
fn uv_area(mesh: &Mesh, f: usize) -> f64 {
    let Some(uvs) = mesh.corners.uvs() else { return 0.0 };
    let [a, b, c] = [0, 1, 2].map(|k| DVec2::new(uvs[3 * f + k][0] as f64, uvs[3 * f + k][1] as f64));
    (b - a).perp_dot(c - a)
}

/// The input's charts ([module docs](self)), each with its own tree for nearest-point queries.
struct Charts {
    /// Per chart: its tree and, per face of the tree, the input face (`None` for a chart without
    /// area).
    trees: Vec<Option<(TriangleBvh, Vec<usize>)>>,
    /// Per texture coordinate value (its bits): the charts that have it at some corner.
    by_value: std::collections::HashMap<[u32; 2], Vec<u32>>,
}

impl Charts {
    fn new(input: &Mesh) -> Option<Charts> {
        let uvs = input.corners.uvs()?;
        let bits = |k: usize| uvs[k].map(f32::to_bits);
        // Faces joined across every edge whose two corners agree on both sides.
        let n = input.face_count();
        let mut parent: Vec<usize> = (0..n).collect();
        fn root(parent: &mut [usize], mut x: usize) -> usize {
            while parent[x] != x {
                parent[x] = parent[parent[x]];
                x = parent[x];
            }
            x
        }
        // The first face seen at each edge; a later one joins it when the values agree (a
        // non-manifold edge's third face is compared with the first).
        let mut first_face: std::collections::HashMap<(u32, u32), usize> = std::collections::HashMap::new();
        for (f, t) in input.triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                let key = (a.min(b), a.max(b));
                match first_face.get(&key) {
                    Some(&g) => {
                        let (fa, fb) = corner_pair(input, f, key);
                        let (ga, gb) = corner_pair(input, g, key);
                        if bits(fa) == bits(ga) && bits(fb) == bits(gb) {
                            let (x, y) = (root(&mut parent, f), root(&mut parent, g));
                            parent[x] = y;
                        }
                    }
                    None => {
                        first_face.insert(key, f);
                    }
                }
            }
        }
        let mut chart_of_root: std::collections::HashMap<usize, u32> = std::collections::HashMap::new();
        let mut faces_of: Vec<Vec<usize>> = Vec::new();
        let chart: Vec<u32> = (0..n)
            .map(|f| {
                let r = root(&mut parent, f);
                let c = *chart_of_root.entry(r).or_insert_with(|| {
                    faces_of.push(Vec::new());
                    faces_of.len() as u32 - 1
                });
                faces_of[c as usize].push(f);
                c
            })
            .collect();
        let mut by_value: std::collections::HashMap<[u32; 2], Vec<u32>> = std::collections::HashMap::new();
        for k in 0..3 * n {
            let list = by_value.entry(bits(k)).or_default();
            if !list.contains(&chart[k / 3]) {
                list.push(chart[k / 3]);
            }
        }
        let mut trees = Vec::with_capacity(faces_of.len());
        let mut local = vec![u32::MAX; input.vertex_count()];
        for faces in faces_of {
            // The chart's own vertices only (a chart is often a small part of a large mesh).
            let mut piece = Mesh::default();
            for &f in &faces {
                let t = input.triangles[f].map(|v| {
                    if local[v as usize] == u32::MAX {
                        local[v as usize] = piece.positions.len() as u32;
                        piece.positions.push(input.positions[v as usize]);
                    }
                    local[v as usize]
                });
                piece.triangles.push(t);
            }
            for &f in &faces {
                input.triangles[f].iter().for_each(|&v| local[v as usize] = u32::MAX);
            }
            trees.push(TriangleBvh::new(&piece).map(|tree| (tree, faces)));
        }
        Some(Charts { trees, by_value })
    }

    /// The charts LOD face `f`'s three corner values all come from; `None` when they have none in
    /// common (or a value is not the input's).
    fn of_face(&self, lod: &Mesh, f: usize) -> Option<Vec<u32>> {
        let uvs = lod.corners.uvs()?;
        let mut common: Vec<u32> = self.by_value.get(&uvs[3 * f].map(f32::to_bits))?.clone();
        for k in 1..3 {
            let these = self.by_value.get(&uvs[3 * f + k].map(f32::to_bits))?;
            common.retain(|c| these.contains(c));
        }
        (!common.is_empty()).then_some(common)
    }

    /// The texture-space distance between `out` and the input's value at the point of `charts`
    /// nearest to `p` (the nearest chart's, when there are several).
    fn nearest_uv_distance(&self, input: &Mesh, charts: &[u32], p: DVec3, out: DVec2) -> f64 {
        let value = self.nearest(charts, p).and_then(|(g, b)| uv_at(input, g, b));
        value.map_or(f64::INFINITY, |value| (out - value).length())
    }

    /// The input face of the point of `charts` nearest to `p` (the first chart's on a tie), with
    /// that point's barycentric coordinates in it.
    fn nearest(&self, charts: &[u32], p: DVec3) -> Option<(usize, [f64; 3])> {
        let mut best: Option<(f64, usize, [f64; 3])> = None;
        for &c in charts {
            let Some((tree, faces)) = &self.trees[c as usize] else { continue };
            let nearest = tree.closest_point(p, None);
            if best.is_some_and(|(d, ..)| nearest.distance() >= d) {
                continue;
            }
            let t = tree.slot_corners(nearest.slot);
            let q = closest_point_on_triangle(p, t[0], t[1], t[2]);
            let b = barycentric(q, t).unwrap_or([1.0, 0.0, 0.0]);
            best = Some((nearest.distance(), faces[tree.slot_face(nearest.slot) as usize], b));
        }
        best.map(|(_, g, b)| (g, b))
    }
}

/// The corners of input face `g` at the lower and the higher vertex of edge `key`.
fn corner_pair(input: &Mesh, g: usize, key: (u32, u32)) -> (usize, usize) {
    let t = input.triangles[g];
    let at = |v: u32| 3 * g + t.iter().position(|&x| x == v).expect("the face has the edge");
    (at(key.0), at(key.1))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(uv_scale: f32) -> Mesh {
        let mut mesh = Mesh::new(
            vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]],
            vec![[0, 1, 2], [0, 2, 3]],
        )
        .unwrap();
        let uv = |v: u32| {
            let p = mesh.positions[v as usize];
            [p[0] * uv_scale, p[1] * uv_scale]
        };
        mesh.corners.set_uvs(Some(mesh.triangles.iter().flatten().map(|&v| uv(v)).collect()));
        mesh.corners.set_normals(Some(vec![[0.0, 0.0, 1.0]; 6]));
        mesh
    }

    #[test]
    fn the_same_surface_has_no_error_and_a_stretched_atlas_has_its_stretch() {
        let a = square(1.0);
        let same = appearance_error(&a, &a, 500, 1024.0, 1).unwrap();
        assert!(same.uv_texels.unwrap().max_sampled < 1e-6, "{same:?}");
        assert!(same.normal_degrees.unwrap().max_sampled < 1e-6, "{same:?}");
        // UVs scaled by 1.5: a point at distance r from the origin is 0.5 r away in texture space.
        let b = square(1.5);
        let error = appearance_error(&a, &b, 4000, 1024.0, 1).unwrap().uv_texels.unwrap();
        let expected_mean = 0.5 * 1024.0 * 0.7652; // mean distance from a corner of the unit square
        assert!((error.mean - expected_mean).abs() < 0.03 * expected_mean, "{error:?} vs {expected_mean}");
        assert!(error.max_sampled <= 0.5 * 1024.0 * 2f64.sqrt() + 1e-6);
    }

    #[test]
    fn a_face_whose_texture_turns_over_is_counted() {
        let a = square(1.0);
        let same = appearance_error(&a, &a, 100, 1024.0, 1).unwrap();
        assert_eq!(same.uv_turned_over, Some(0));
        // The second face's last two corners swap their values: the same values, the other way round.
        let mut b = a.clone();
        b.corners.uvs_mut().unwrap().swap(4, 5);
        assert_eq!(appearance_error(&a, &b, 100, 1024.0, 1).unwrap().uv_turned_over, Some(1));
        // Without texture coordinates nothing is counted.
        b.corners.set_uvs(None);
        assert_eq!(appearance_error(&a, &b, 100, 1024.0, 1).unwrap().uv_turned_over, None);
    }

    #[test]
    fn a_seam_compares_each_side_with_its_own_chart() {
        // Two triangles meeting on the diagonal, each with its own chart far apart: samples on
        // the diagonal have two input values, and the nearer one counts.
        let mut a = square(1.0);
        let uvs = a.corners.uvs_mut().unwrap();
        uvs[3..6].iter_mut().for_each(|uv| uv[0] += 5.0);
        let error = appearance_error(&a, &a, 2000, 1024.0, 7).unwrap().uv_texels.unwrap();
        assert!(error.max_sampled < 1e-6, "{error:?}");
    }

    #[test]
    fn a_layer_is_compared_with_its_own_chart_not_the_one_beneath() {
        // Two layers a millimetre apart (a garment and its lining), each its own chart; the LOD
        // keeps the top layer's values but sags to just above the lining.
        let top = square(1.0);
        let mut lining = square(1.0);
        lining.positions.iter_mut().for_each(|p| p[2] = -0.001);
        lining.corners.uvs_mut().unwrap().iter_mut().for_each(|uv| uv[1] += 3.0);
        let mut input = top.clone();
        input.positions.extend(&lining.positions);
        input.triangles.extend(lining.triangles.iter().map(|t| t.map(|v| v + 4)));
        let uvs = input.corners.uvs_mut().unwrap();
        uvs.extend(lining.corners.uvs().unwrap());
        let normals = input.corners.normals_mut().unwrap();
        normals.extend(lining.corners.normals().unwrap());
        let mut lod = top.clone();
        lod.positions.iter_mut().for_each(|p| p[2] = -0.0009);
        let measured = appearance_error(&input, &lod, 1000, 1024.0, 3).unwrap();
        let error = measured.uv_texels.unwrap();
        assert!(error.max_sampled < 1e-3, "{error:?}");
        assert!(measured.uv_texels_any_chart.unwrap().mean > 1000.0, "{measured:?}");
        // A value the input never had has no chart: the nearest point decides, as before.
        lod.corners.uvs_mut().unwrap().iter_mut().for_each(|uv| uv[0] += 0.25);
        let error = appearance_error(&input, &lod, 1000, 1024.0, 3).unwrap().uv_texels.unwrap();
        assert!(error.mean > 1000.0, "compared with the lining: {error:?}");
    }
}
