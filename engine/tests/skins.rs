//! Skinned glTF: joints and weights kept per corner, the skeleton, skin and animations carried to
//! the written glTF, and bad skins refused by name. A procedural asset here; the shared skinned
//! assets (CesiumMan, Fox) go through the same paths in attributes.rs and scripts/test.sh.

use std::path::Path;

use base64::Engine as _;
use meshlod_engine::io::{MeshFormat, ReadLimits, read_mesh_bytes, write_mesh_to};

/// A skinned strip of 4 triangles (a 2×3 grid of vertices) under a parent node that is moved by
/// (5, 0, 0) — which a skinned mesh ignores — with a two-joint skin and an animation of one joint.
/// `bad_joint` is written as the joint of the last vertex; `middle` as the weights of vertex 2.
fn skinned_gltf(bad_joint: u16) -> String {
    skinned_gltf_with(bad_joint, [0.5, 0.5, 0.0, 0.0])
}

fn skinned_gltf_with(bad_joint: u16, middle: [f32; 4]) -> String {
    let mut bin = Vec::new();
    let positions: [[f32; 3]; 6] = [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [1., 1., 0.], [0., 2., 0.], [1., 2., 0.]];
    positions.iter().flatten().for_each(|c| bin.extend_from_slice(&c.to_le_bytes()));
    let indices: [u16; 12] = [0, 1, 2, 1, 3, 2, 2, 3, 4, 3, 5, 4];
    indices.iter().for_each(|i| bin.extend_from_slice(&i.to_le_bytes())); // 72..96
    let joints: [[u16; 4]; 6] =
        [[0, 0, 0, 0], [0, 0, 0, 0], [0, 1, 0, 0], [0, 1, 0, 0], [1, 0, 0, 0], [bad_joint, 0, 0, 0]];
    joints.iter().flatten().for_each(|j| bin.extend_from_slice(&j.to_le_bytes())); // 96..144
    let weights: [[f32; 4]; 6] =
        [[1., 0., 0., 0.], [1., 0., 0., 0.], middle, [0.5, 0.5, 0., 0.], [1., 0., 0., 0.], [1., 0., 0., 0.]];
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
    assert_eq!((back.corners.joints(), back.corners.weights()), (mesh.corners.joints(), mesh.corners.weights()));
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
    assert!(obj.corners.joints().is_none());
}

#[test]
fn simplified_and_refined_skins_stay_consistent() {
    use meshlod_engine::simplify::{SimplifyOptions, simplify};
    let mesh = read(&skinned_gltf(1)).unwrap();
    let lod = simplify(&mesh, &SimplifyOptions { target_faces: Some(2), ..Default::default() }).unwrap().mesh;
    lod.check().unwrap();
    let (joints, weights) = (lod.corners.joints().unwrap(), lod.corners.weights().unwrap());
    let input: Vec<([u16; 4], [f32; 4])> = mesh
        .corners
        .joints()
        .into_iter()
        .flatten()
        .copied()
        .zip(mesh.corners.weights().into_iter().flatten().copied())
        .collect();
    for (j, w) in joints.iter().zip(weights) {
        assert!(input.contains(&(*j, *w)), "a corner's skin the input never had: {j:?} {w:?}");
    }
    let refined = meshlod_engine::refine::subdivide::subdivide_uniform(&mesh);
    refined.check().unwrap();
    for w in refined.corners.weights().unwrap() {
        let sum = w.iter().fold(0f32, |s, &x| s + x) as f64;
        assert!((sum - 1.0).abs() <= 2e-7 * w.iter().filter(|&&x| x != 0.0).count() as f64, "{w:?}");
    }
}

/// Weights that do not sum to 1 (invalid glTF, as in the shared CesiumMan) are scaled to sum to 1
/// when read, said; the sums the Khronos validator takes (in order, in single precision) are then
/// within its tolerance, here and for arbitrary weights.
#[test]
fn weights_that_do_not_sum_to_one_are_mended_and_said() {
    use meshlod_engine::mesh::normalize_weights;
    let validator_sum_ok = |w: &[f32; 4]| {
        let sum = w.iter().fold(0f32, |s, &x| s + x) as f64;
        (sum - 1.0).abs() <= 2e-7 * w.iter().filter(|&&x| x != 0.0).count() as f64 && w.iter().all(|&x| x >= 0.0)
    };
    let mesh = read(&skinned_gltf_with(1, [0.25, 0.25, 0.0, 0.0])).unwrap();
    let weights = mesh.corners.weights().unwrap();
    assert!(weights.iter().all(validator_sum_ok) && weights.contains(&[0.5, 0.5, 0.0, 0.0]), "{weights:?}");
    let said: Vec<String> = mesh.corners.input_warnings().collect();
    assert!(said.iter().any(|w| w.contains("WEIGHTS_0") && w.contains("at 1 vertices")), "{said:?}");
    assert!(read(&skinned_gltf(1)).unwrap().corners.input_warnings().next().is_none(), "nothing to mend");
    // Arbitrary weights (some zero, some negative): mended within the tolerance; valid ones kept.
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    for _ in 0..20_000 {
        let mut w = [0.0; 4].map(|_| match next() {
            x if x < 0.3 => 0.0,
            x if x < 0.35 => -x,
            _ => next() * 3.0,
        });
        let before = w;
        let changed = normalize_weights(&mut w);
        if before.iter().any(|&x| x > 0.0) {
            assert!(validator_sum_ok(&w), "{before:?} → {w:?}");
        }
        assert_eq!(changed, w != before, "{before:?}");
        let mut again = w;
        assert!(!normalize_weights(&mut again) || !before.iter().any(|&x| x > 0.0), "{before:?}: stable");
    }
}

#[test]
fn a_joint_outside_the_skin_is_refused_by_name() {
    let e = read(&skinned_gltf(7)).unwrap_err().to_string();
    assert!(e.contains("JOINTS_0") && e.contains("joint 7") && e.contains("the skin has 2"), "{e}");
}
