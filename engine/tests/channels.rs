//! A channel the engine has no meaning for (a glTF `_FEATURE_ID_0`, as EXT_mesh_features and
//! 3D Tiles write them) goes through glTF in and out, simplification, both `.pm` forms and the
//! progressive mesh's levels as the channels the engine knows do: only the glTF reader and writer
//! know it is there.

use std::path::Path;

use meshlod_engine::io::{MeshFormat, read_mesh, unwritten_warning, write_mesh};
use meshlod_engine::mesh::{Semantic, Values};
use meshlod_engine::simplify::{SimplifyOptions, simplify};
use meshlod_engine::{Mesh, procedural};

mod common;
use common::tempdir;

fn feature() -> Semantic {
    Semantic::Custom("_FEATURE_ID_0".into())
}

/// The feature ids of `mesh`'s corners.
fn ids(mesh: &Mesh) -> &[[f32; 1]] {
    match mesh.corners.channel(&feature()) {
        Some(Values::F1(v)) => v,
        other => panic!("no _FEATURE_ID_0 channel of one float: {other:?}"),
    }
}

/// A torus whose faces belong to four features by the quadrant of their centre, each corner
/// carrying its face's id: a vertex on a border between features has two ids (a seam), as a
/// vertex between two materials does.
fn featured_torus() -> Mesh {
    let mut mesh = procedural::torus(48, 24, 0.3);
    let ids: Vec<[f32; 1]> = (0..mesh.face_count())
        .flat_map(|f| {
            let [a, b, c] = mesh.triangle_points(f);
            let centre = (a + b + c) / 3.0;
            let quadrant = (centre.y >= 0.0) as u8 * 2 + (centre.x >= 0.0) as u8;
            [[f32::from(quadrant)]; 3]
        })
        .collect();
    mesh.corners.set(feature(), Some(Values::F1(ids)));
    mesh.check().unwrap();
    mesh
}

/// Every face's three corners carry one id, and the ids are the input's.
fn assert_faces_have_one_feature(mesh: &Mesh, what: &str) {
    let ids = ids(mesh);
    assert_eq!(ids.len(), 3 * mesh.face_count(), "{what}: one id per corner");
    for (f, corners) in ids.chunks_exact(3).enumerate() {
        assert!(corners[0] == corners[1] && corners[1] == corners[2], "{what}: face {f} has ids {corners:?}");
        assert!((0.0..4.0).contains(&corners[0][0]) && corners[0][0].fract() == 0.0, "{what}: {corners:?}");
    }
}

#[test]
fn a_custom_channel_goes_through_gltf_simplify_and_the_progressive_mesh() {
    let dir = tempdir("channels");
    let mesh = featured_torus();
    assert!(mesh.corners.names().contains(&"_FEATURE_ID_0"));
    let seams = meshlod_engine::validate::validate(&mesh).seam_edges;
    assert!(seams >= 4 * 24, "the borders between features are seams ({seams} seam edges)");

    // glTF out and in: an accessor named _FEATURE_ID_0, the same ids back.
    let glb = dir.join("featured.glb");
    write_mesh(&glb, &mesh).unwrap();
    let bytes = std::fs::read(&glb).unwrap();
    let json_length = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let json = std::str::from_utf8(&bytes[20..20 + json_length]).unwrap();
    assert!(json.contains("\"_FEATURE_ID_0\""), "{json}");
    let read = read_mesh(&glb).unwrap();
    assert_eq!(read.triangles, mesh.triangles);
    assert!(ids(&read) == ids(&mesh), "the ids read back bit for bit");

    // Simplified to a quarter: the channel kept on every face, the borders kept as seams.
    let options = SimplifyOptions { target_ratio: Some(0.75), record_progressive: true, ..Default::default() };
    let out = simplify(&read, &options).unwrap();
    assert!(out.mesh.face_count() <= read.face_count() / 4 + 8, "{} faces", out.mesh.face_count());
    assert_faces_have_one_feature(&out.mesh, "simplified");
    let features: std::collections::BTreeSet<u32> = ids(&out.mesh).iter().map(|v| v[0] as u32).collect();
    assert_eq!(features.len(), 4, "every feature keeps faces: {features:?}");

    // Both .pm forms carry it: every level of the file is the level of the progressive mesh.
    let pm = out.progressive.as_ref().unwrap();
    for (form, bytes) in [
        ("compact", meshlod_engine::pm_format::encode(pm)),
        ("lossless", meshlod_engine::pm_format::encode_lossless(pm)),
    ] {
        let back = meshlod_engine::pm_format::decode(&bytes, Path::new("featured.pm")).unwrap().0;
        for level in [0, pm.levels() / 3, pm.levels()] {
            let (want, got) = (pm.at_level(level), back.at_level(level));
            assert!(ids(&got) == ids(&want), "{form}: level {level}: the ids differ");
            assert_faces_have_one_feature(&got, form);
        }
        // Refined all the way: the input's faces (in the progressive mesh's order), so each
        // feature's share of the corners is the input's.
        let count = |m: &Mesh| (0..4).map(|i| ids(m).iter().filter(|v| v[0] == i as f32).count()).collect::<Vec<_>>();
        assert_eq!(count(&back.at_level(back.levels())), count(&read), "{form}: refined back to the input");
        // A cut file is refused, never read with the channel half there.
        assert!(meshlod_engine::pm_format::decode(&bytes[..bytes.len() - 9], Path::new("cut.pm")).is_err());
    }

    // The simplified mesh as glTF again: the same ids.
    let lod = dir.join("lod.gltf");
    write_mesh(&lod, &out.mesh).unwrap();
    let back = read_mesh(&lod).unwrap();
    assert_eq!(back.triangles.len(), out.mesh.triangles.len());
    assert!(ids(&back) == ids(&out.mesh), "the simplified ids read back");

    // A format without a place for it says so by the channel's name.
    let warning = unwritten_warning(MeshFormat::Obj, &out.mesh).expect("OBJ cannot hold it");
    assert!(warning.contains("_FEATURE_ID_0"), "{warning}");
    assert!(unwritten_warning(MeshFormat::Gltf, &out.mesh).is_none());
}
