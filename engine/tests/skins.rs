//! Skinned glTF: joints and weights kept per corner, the skeleton, skin and animations carried to
//! the written glTF, and bad skins refused by name. A procedural asset here; the shared skinned
//! assets (CesiumMan, Fox) go through the same paths in attributes.rs and scripts/test.sh.

use std::path::Path;

use base64::Engine as _;
use meshlod_engine::io::{MeshFormat, ReadLimits, read_mesh_bytes, write_mesh_to};

/// A skinned strip of 4 triangles (a 2×3 grid of vertices) under a parent node that is moved by
/// (5, 0, 0) — which a skinned mesh ignores — with a two-joint skin and an animation of one joint.
/// `bad_joint` is written as the joint of the last vertex.
fn skinned_gltf(bad_joint: u16) -> String {
    let mut bin = Vec::new();
    let positions: [[f32; 3]; 6] = [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [1., 1., 0.], [0., 2., 0.], [1., 2., 0.]];
    positions.iter().flatten().for_each(|c| bin.extend_from_slice(&c.to_le_bytes()));
    let indices: [u16; 12] = [0, 1, 2, 1, 3, 2, 2, 3, 4, 3, 5, 4];
    indices.iter().for_each(|i| bin.extend_from_slice(&i.to_le_bytes())); // 72..96
    let joints: [[u16; 4]; 6] =
        [[0, 0, 0, 0], [0, 0, 0, 0], [0, 1, 0, 0], [0, 1, 0, 0], [1, 0, 0, 0], [bad_joint, 0, 0, 0]];
    joints.iter().flatten().for_each(|j| bin.extend_from_slice(&j.to_le_bytes())); // 96..144
    let weights: [[f32; 4]; 6] = [
        [1., 0., 0., 0.],
        [1., 0., 0., 0.],
        [0.5, 0.5, 0., 0.],
        [0.5, 0.5, 0., 0.],
        [1., 0., 0., 0.],
        [1., 0., 0., 0.],
    ];
    weights.iter().flatten().for_each(|w| bin.extend_from_slice(&w.to_le_bytes())); // 144..240
    let identity: [f32; 16] = [1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1.];
    for _ in 0..2 {
        identity.iter().for_each(|c| bin.extend_from_slice(&c.to_le_bytes())); // 240..368
    }
    [0f32, 1.].iter().for_each(|t| bin.extend_from_slice(&t.to_le_bytes())); // 368..376
    [0f32, 1., 0., 0., 2., 0.].iter().for_each(|c| bin.extend_from_slice(&c.to_le_bytes())); // 376..400
    let uri =
        format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&bin));
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
        "nodes":[{{"translation":[5,0,0],"children":[1,2]}},{{"mesh":0,"skin":0}},{{"name":"root","children":[3]}},{{"name":"tip","translation":[0,1,0]}}],
        "skins":[{{"joints":[2,3],"inverseBindMatrices":4}}],
        "animations":[{{"channels":[{{"sampler":0,"target":{{"node":3,"path":"translation"}}}}],"samplers":[{{"input":5,"output":6}}]}}],
        "buffers":[{{"byteLength":{},"uri":"{uri}"}}],
        "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":72}},{{"buffer":0,"byteOffset":72,"byteLength":24}},
          {{"buffer":0,"byteOffset":96,"byteLength":48}},{{"buffer":0,"byteOffset":144,"byteLength":96}},
          {{"buffer":0,"byteOffset":240,"byteLength":128}},{{"buffer":0,"byteOffset":368,"byteLength":8}},
          {{"buffer":0,"byteOffset":376,"byteLength":24}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":6,"type":"VEC3","min":[0,0,0],"max":[1,2,0]}},
          {{"bufferView":1,"componentType":5123,"count":12,"type":"SCALAR"}},
          {{"bufferView":2,"componentType":5123,"count":6,"type":"VEC4"}},
          {{"bufferView":3,"componentType":5126,"count":6,"type":"VEC4"}},
          {{"bufferView":4,"componentType":5126,"count":2,"type":"MAT4"}},
          {{"bufferView":5,"componentType":5126,"count":2,"type":"SCALAR","min":[0],"max":[1]}},
          {{"bufferView":6,"componentType":5126,"count":2,"type":"VEC3"}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"JOINTS_0":2,"WEIGHTS_0":3}},"indices":1}}]}}]}}"#,
        bin.len()
    )
}

fn read(text: &str) -> Result<meshlod_engine::mesh::Mesh, meshlod_engine::error::MeshError> {
    read_mesh_bytes(text.as_bytes(), Some(MeshFormat::Gltf), Path::new("skinned.gltf"), &ReadLimits::default())
}

#[test]
fn a_skinned_mesh_keeps_its_joints_weights_skeleton_and_animation_through_glb() {
    let mesh = read(&skinned_gltf(1)).unwrap();
    assert_eq!(mesh.face_count(), 4);
    assert!(mesh.corners.names().contains(&"joints") && mesh.corners.names().contains(&"weights"));
    // Bind space: the parent's translation is not applied to a skinned mesh.
    let bounds = mesh.surface_bounds().unwrap();
    assert_eq!((bounds.min[0], bounds.max[0]), (0.0, 1.0));
    let rig = mesh.corners.library.as_ref().and_then(|l| l.rig.as_ref()).expect("the rig is carried");
    assert_eq!((rig.joint_count(), rig.mesh_node, rig.animations.len(), rig.accessors.len()), (2, 1, 1, 3));
    let lib = mesh.corners.library.as_ref().unwrap();
    assert!(lib.not_carried.is_empty(), "{:?}", lib.not_carried);

    let mut glb = Vec::new();
    write_mesh_to(&mut glb, &mesh, MeshFormat::Gltf).unwrap();
    let back = read_mesh_bytes(&glb, Some(MeshFormat::Gltf), Path::new("back.glb"), &ReadLimits::default()).unwrap();
    assert_eq!(back.positions, mesh.positions);
    assert_eq!(back.triangles, mesh.triangles);
    assert_eq!((&back.corners.joints, &back.corners.weights), (&mesh.corners.joints, &mesh.corners.weights));
    let back_rig = back.corners.library.as_ref().and_then(|l| l.rig.as_ref()).unwrap();
    assert_eq!(back_rig.skins, rig.skins);
    assert_eq!(back_rig.animations, rig.animations);
    assert_eq!(back_rig.accessors, rig.accessors, "the skin's matrices and the animation's keys, byte for byte");
    // The written document: the skinned node draws the mesh, the others draw nothing.
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let doc: serde_json::Value = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
    assert_eq!(doc["nodes"][1]["mesh"], 0);
    assert_eq!(doc["nodes"][1]["skin"], 0);
    assert_eq!(doc["nodes"][0]["translation"], serde_json::json!([5, 0, 0]));
    let attributes = &doc["meshes"][0]["primitives"][0]["attributes"];
    assert!(attributes.get("JOINTS_0").is_some() && attributes.get("WEIGHTS_0").is_some(), "{attributes}");

    // Written where the format has no skin: the joints go, and nothing claims otherwise.
    let mut obj = Vec::new();
    write_mesh_to(&mut obj, &mesh, MeshFormat::Obj).unwrap();
    let obj = read_mesh_bytes(&obj, Some(MeshFormat::Obj), Path::new("back.obj"), &ReadLimits::default()).unwrap();
    assert!(obj.corners.joints.is_none());
}

#[test]
fn simplified_and_refined_skins_stay_consistent() {
    use meshlod_engine::simplify::{SimplifyOptions, simplify};
    let mesh = read(&skinned_gltf(1)).unwrap();
    let lod = simplify(&mesh, &SimplifyOptions { target_faces: Some(2), ..Default::default() }).unwrap().mesh;
    lod.check().unwrap();
    let (joints, weights) = (lod.corners.joints.as_ref().unwrap(), lod.corners.weights.as_ref().unwrap());
    let input: Vec<([u16; 4], [f32; 4])> =
        mesh.corners.joints.iter().flatten().copied().zip(mesh.corners.weights.iter().flatten().copied()).collect();
    for (j, w) in joints.iter().zip(weights) {
        assert!(input.contains(&(*j, *w)), "a corner's skin the input never had: {j:?} {w:?}");
    }
    let refined = meshlod_engine::refine::subdivide::subdivide_uniform(&mesh);
    refined.check().unwrap();
    for w in refined.corners.weights.as_ref().unwrap() {
        assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-6, "{w:?}");
    }
}

#[test]
fn a_joint_outside_the_skin_is_refused_by_name() {
    let e = read(&skinned_gltf(7)).unwrap_err().to_string();
    assert!(e.contains("JOINTS_0") && e.contains("joint 7") && e.contains("the skin has 2"), "{e}");
}
