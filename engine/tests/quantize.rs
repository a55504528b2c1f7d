//! glTF written with `KHR_mesh_quantization` (`WriteOptions::quantize`): the file says it needs the
//! extension, reads back within the grid's bounds, and is smaller; on a procedural mesh and on
//! every shared textured asset.

use std::path::Path;

use meshlod_engine::io::{
    MeshFormat, ReadLimits, WriteOptions, read_mesh, read_mesh_bytes, write_gltf_with, write_mesh_with,
};
use meshlod_engine::simplify::{SimplifyOptions, simplify};
use meshlod_engine::{Mesh, procedural};
use serde_json::Value;

mod common;

const QUANTIZED: WriteOptions = WriteOptions { quantize: true };

fn glb(mesh: &Mesh, options: &WriteOptions) -> Vec<u8> {
    let mut bytes = Vec::new();
    write_gltf_with(&mut bytes, mesh, true, None, options).unwrap();
    bytes
}

/// The JSON chunk of a GLB.
fn document(glb: &[u8]) -> Value {
    let length = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    serde_json::from_slice(&glb[20..20 + length]).unwrap()
}

/// Bytes of the vertex data (the buffer views for vertex attributes).
fn vertex_bytes(json: &Value) -> u64 {
    let views = json["bufferViews"].as_array().unwrap();
    views.iter().filter(|v| v["target"] == 34962).map(|v| v["byteLength"].as_u64().unwrap()).sum()
}

fn read(glb: &[u8]) -> Mesh {
    read_mesh_bytes(glb, Some(MeshFormat::Gltf), Path::new("q.glb"), &ReadLimits::default()).unwrap()
}

fn corner_positions(m: &Mesh) -> Vec<[f32; 3]> {
    m.triangles.iter().flatten().map(|&v| m.positions[v as usize]).collect()
}

fn distance(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f32>().sqrt()
}

/// The farthest a position may move on the grid: half a step along each axis, the step being the
/// largest side over 65 535 (and some room for the f32 arithmetic of undoing it).
fn position_bound(mesh: &Mesh) -> f32 {
    let b = mesh.bounds().unwrap();
    let side = (0..3).map(|k| b.max[k] - b.min[k]).fold(0.0, f64::max) as f32;
    0.5 * 3f32.sqrt() * side / 65535.0 * 1.01 + side * 1e-6
}

/// A sphere with per-corner unit normals, texture coordinates in [0, 1] and colours.
fn painted_sphere(uv_scale: f32) -> Mesh {
    let mut mesh = procedural::icosphere(3);
    let corner = |k: usize| mesh.positions[mesh.triangles[k / 3][k % 3] as usize];
    let corners = 3 * mesh.face_count();
    let normals: Vec<[f32; 3]> = (0..corners).map(|k| corner(k).map(|c| c / distance(&corner(k), &[0.0; 3]))).collect();
    let uvs: Vec<[f32; 2]> =
        (0..corners).map(&corner).map(|p| [uv_scale * 0.5 * (p[0] + 1.0), 0.5 * (p[1] + 1.0)]).collect();
    let colors: Vec<[f32; 4]> = (0..corners).map(&corner).map(|p| [p[0].abs(), p[1].abs(), p[2].abs(), 1.0]).collect();
    mesh.corners.set_normals(Some(normals));
    mesh.corners.set_uvs(Some(uvs));
    mesh.corners.set_colors(Some(colors));
    mesh.check().unwrap();
    mesh
}

#[test]
fn quantized_gltf_reads_back_within_its_grid_and_is_smaller() {
    let mesh = painted_sphere(1.0);
    let (float, quantized) = (glb(&mesh, &WriteOptions::default()), glb(&mesh, &QUANTIZED));
    let (v_float, v_quantized) = (vertex_bytes(&document(&float)), vertex_bytes(&document(&quantized)));
    assert!(2 * v_quantized <= v_float, "vertex data: {v_quantized} bytes quantized against {v_float} in floats");
    assert!(quantized.len() < float.len());
    let json = document(&quantized);
    assert_eq!(json["extensionsRequired"], serde_json::json!(["KHR_mesh_quantization"]));
    assert_eq!(json["extensionsUsed"], serde_json::json!(["KHR_mesh_quantization"]));
    assert!(document(&float).get("extensionsRequired").is_none(), "floats need no extension");
    let attributes = &json["meshes"][0]["primitives"][0]["attributes"];
    let component =
        |name: &str| json["accessors"][attributes[name].as_u64().unwrap() as usize]["componentType"].clone();
    assert_eq!(
        [component("POSITION"), component("NORMAL"), component("TEXCOORD_0")],
        [5123, 5120, 5123].map(Value::from)
    );

    let back = read(&quantized);
    assert_eq!(back.face_count(), mesh.face_count());
    assert_eq!(back.corners.names(), read(&float).corners.names());
    let bound = position_bound(&mesh);
    let worst =
        corner_positions(&back).iter().zip(corner_positions(&mesh)).map(|(a, b)| distance(a, &b)).fold(0.0, f32::max);
    assert!(worst <= bound, "a position moved {worst}, more than the grid allows ({bound})");
    assert!(worst > 0.0, "the positions were not quantized");
    let pairs = |a: Option<&Vec<[f32; 3]>>, b: Option<&Vec<[f32; 3]>>| {
        a.unwrap().iter().zip(b.unwrap()).map(|(x, y)| (*x, *y)).collect::<Vec<_>>()
    };
    for (n, m) in pairs(back.corners.normals(), mesh.corners.normals()) {
        let cos = n.iter().zip(&m).map(|(a, b)| a * b).sum::<f32>() / distance(&n, &[0.0; 3]);
        assert!(cos > 1f32.to_radians().cos(), "a normal turned by {}°", cos.acos().to_degrees());
    }
    let uvs = mesh.corners.uvs_with_origin(true).unwrap();
    for (a, b) in back.corners.uvs().unwrap().iter().zip(uvs.iter()) {
        assert!(distance(a, b) <= 0.5 * 2f32.sqrt() / 65535.0 + 1e-7, "{a:?} for {b:?}");
    }
    for (a, b) in back.corners.colors().unwrap().iter().zip(mesh.corners.colors().unwrap()) {
        assert!(distance(a, b) <= 1.0 / 65535.0 + 1e-7, "{a:?} for {b:?}");
    }
}

#[test]
fn texture_coordinates_beyond_the_unit_square_are_signed_or_float_and_other_formats_refuse_the_option() {
    let mesh = painted_sphere(3.0);
    let bytes = glb(&mesh, &QUANTIZED);
    let json = document(&bytes);
    let attributes = &json["meshes"][0]["primitives"][0]["attributes"];
    let uv = &json["accessors"][attributes["TEXCOORD_0"].as_u64().unwrap() as usize];
    assert_eq!(uv["componentType"], 5126, "a repeating texture's coordinates are not clamped");
    assert_eq!(read(&bytes).corners.uvs().map(Vec::as_slice), mesh.corners.uvs_with_origin(true).as_deref());
    // Within [-1, 1]: signed normalised shorts.
    let mirrored = painted_sphere(-1.0);
    let bytes = glb(&mirrored, &QUANTIZED);
    let json = document(&bytes);
    let attributes = &json["meshes"][0]["primitives"][0]["attributes"];
    assert_eq!(json["accessors"][attributes["TEXCOORD_0"].as_u64().unwrap() as usize]["componentType"], 5122);
    let uvs = mirrored.corners.uvs_with_origin(true).unwrap();
    for (a, b) in read(&bytes).corners.uvs().unwrap().iter().zip(uvs.iter()) {
        assert!(distance(a, b) <= 0.5 * 2f32.sqrt() / 32767.0 + 1e-7, "{a:?} for {b:?}");
    }

    let dir = common::tempdir("quantize");
    for name in ["sphere.obj", "sphere.ply"] {
        let e = write_mesh_with(dir.join(name), &mesh, &QUANTIZED).unwrap_err().to_string();
        assert!(e.contains("quantize") && e.contains(".glb"), "{e}");
        assert!(!dir.join(name).exists(), "nothing written");
    }
    write_mesh_with(dir.join("sphere.gltf"), &mesh, &QUANTIZED).unwrap();
    assert_eq!(read_mesh(dir.join("sphere.gltf")).unwrap().face_count(), mesh.face_count());
}

#[test]
fn every_shared_textured_asset_at_ten_percent_quantizes_within_its_grid() {
    let Some(dir) = meshlod_engine::datasets::require_shared_textured("quantize") else { return };
    let manifest = std::fs::read_to_string(dir.join("MANIFEST.tsv")).unwrap();
    let assets: Vec<_> = manifest.lines().skip(1).filter_map(|l| l.split('\t').next()).collect();
    assert!(assets.len() >= 7, "{assets:?}");
    let out = common::tempdir("quantize-assets");
    for asset in assets {
        let input = read_mesh(dir.join(asset)).unwrap();
        let options = SimplifyOptions { target_ratio: Some(0.9), ..Default::default() };
        let lod = simplify(&input, &options).unwrap().mesh;
        // Written to files: an image the input names but lacks stays a reference beside them.
        let (float, quantized) = (out.join("float.glb"), out.join("quantized.glb"));
        write_mesh_with(&float, &lod, &WriteOptions::default()).unwrap();
        write_mesh_with(&quantized, &lod, &QUANTIZED).unwrap();
        let (float, quantized) = (std::fs::read(float).unwrap(), std::fs::read(quantized).unwrap());
        let (v_float, v_quantized) = (vertex_bytes(&document(&float)), vertex_bytes(&document(&quantized)));
        assert!(v_quantized < v_float, "{asset}: vertex data {v_quantized} bytes against {v_float}");
        let (from_float, back) = (read(&float), read(&quantized));
        assert_eq!(back.face_count(), from_float.face_count(), "{asset}");
        assert_eq!(back.corners.names(), from_float.corners.names(), "{asset}");
        let skinned = back.corners.joints().is_some();
        let bound = if skinned { 0.0 } else { position_bound(&from_float) };
        let worst = corner_positions(&back)
            .iter()
            .zip(corner_positions(&from_float))
            .map(|(a, b)| distance(a, &b))
            .fold(0.0, f32::max);
        assert!(worst <= bound, "{asset}: a position moved {worst} (bound {bound}; skinned {skinned})");
    }
}
