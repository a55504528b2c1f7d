//! SimplifyStream with attributes, over real loopback gRPC: the base's and every split's corner
//! values arrive with them, and the reassembled progressive mesh has, level for level, the same
//! corners as the `.pm` file the unary Simplify returns for the same request.

mod common;

use common::loopback::TestServer;
use meshlod_engine::{Mesh, procedural};
use meshlod_service::convert::mesh_to_proto;
use meshlod_service::proto;
use meshlod_service::server::ServerConfig;
use meshlod_service::stream_values::progressive_from_stream;

/// A sphere with a texture seam around its equator (each half its own chart and colour) and smooth
/// normals: every kind of value a contract `Mesh` carries.
fn textured_sphere() -> Mesh {
    let mut sphere = procedural::icosphere(3);
    let (mut uvs, mut normals, mut colors) = (Vec::new(), Vec::new(), Vec::new());
    for f in 0..sphere.face_count() {
        let upper = sphere.triangle_points(f).iter().map(|p| p.z).sum::<f64>() > 0.0;
        for &v in &sphere.triangles[f] {
            let p = sphere.positions[v as usize];
            uvs.push([0.25 * (p[0] + 1.0) + if upper { 0.5 } else { 0.0 }, 0.5 * (p[1] + 1.0)]);
            let length = p.iter().map(|c| c * c).sum::<f32>().sqrt();
            normals.push(p.map(|c| c / length));
            colors.push(if upper { [1.0, 0.5, 0.0, 1.0] } else { [0.0, 0.5, 1.0, 1.0] });
        }
    }
    sphere.corners.set_uvs(Some(uvs));
    sphere.corners.set_normals(Some(normals));
    sphere.corners.set_colors(Some(colors));
    sphere
}

fn request(mesh: &Mesh) -> proto::SimplifyRequest {
    proto::SimplifyRequest {
        input: Some(proto::MeshInput { source: Some(proto::mesh_input::Source::Mesh(mesh_to_proto(mesh))) }),
        options: Some(proto::SimplifyOptions {
            target_ratio: Some(0.9),
            return_progressive: true,
            progressive_lossless: true,
            ..Default::default()
        }),
        ..Default::default()
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn streamed_splits_carry_their_corner_values() {
    let server = TestServer::start(ServerConfig { stream_message_bytes: 2048, ..Default::default() }).await;
    let mut client = server.client().await;
    let mesh = textured_sphere();
    let mut stream = client.simplify_stream(request(&mesh)).await.unwrap().into_inner();
    let (mut base, mut base_corners, mut splits, mut stats, mut batches) = (None, None, Vec::new(), None, 0);
    while let Some(message) = stream.message().await.unwrap() {
        use proto::simplify_stream_message::Item;
        match message.item.unwrap() {
            Item::Base(b) => base = Some(b),
            Item::BaseCorners(c) => {
                assert!(base.is_some() && splits.is_empty(), "the base's values come right after the base");
                base_corners = Some(c);
            }
            Item::Splits(batch) => {
                assert_eq!(batch.first as usize, splits.len(), "batches arrive in order");
                assert!(prost::Message::encoded_len(&batch) <= 2048, "a batch over the message size");
                splits.extend(batch.splits);
                batches += 1;
            }
            Item::Stats(s) => stats = Some(s),
        }
    }
    let stats = stats.expect("stats come last");
    assert!(
        batches > 1,
        "a small message size splits the stream: {batches} batches, {} splits, {stats:?}",
        splits.len()
    );
    assert!(stats.warnings.is_empty(), "nothing is left out: {:?}", stats.warnings);
    let base = base.expect("the base comes first");
    let streamed = progressive_from_stream(&base, base_corners.as_ref(), &splits).unwrap();
    assert_eq!(streamed.base().corners.names(), ["normal", "uv", "color"]);

    // The unary call's lossless `.pm` for the same request: the same levels, corner for corner.
    let response = client.simplify(request(&mesh)).await.unwrap().into_inner();
    let file = response.progressive.unwrap().file;
    let unary = meshlod_engine::pm_format::decode(&file, std::path::Path::new("unary.pm")).unwrap().0;
    assert_eq!(streamed.levels(), unary.levels());
    for level in [0, streamed.levels() / 2, streamed.levels()] {
        let (a, b) = (streamed.at_level(level), unary.at_level(level));
        assert_eq!((&a.positions, &a.triangles), (&b.positions, &b.triangles), "level {level}");
        assert_eq!(a.corners.normals(), b.corners.normals(), "level {level}");
        assert_eq!(a.corners.colors(), b.corners.colors(), "level {level}");
        assert_eq!(a.corners.uvs_with_origin(false), b.corners.uvs_with_origin(false), "level {level}");
    }
    // Fully refined, every corner has the input's values.
    let full = streamed.at_level(streamed.levels());
    assert_eq!(full.face_count(), mesh.face_count());
    let key = |m: &Mesh, k: usize| {
        let mut key: Vec<u32> = m.positions[m.triangles[k / 3][k % 3] as usize].map(f32::to_bits).to_vec();
        key.extend(m.corners.uvs_with_origin(false).unwrap()[k].map(f32::to_bits));
        key.extend(m.corners.normals().unwrap()[k].map(f32::to_bits));
        key
    };
    let mut got: Vec<Vec<u32>> = (0..3 * full.face_count()).map(|k| key(&full, k)).collect();
    let mut want: Vec<Vec<u32>> = (0..3 * mesh.face_count()).map(|k| key(&mesh, k)).collect();
    got.sort();
    want.sort();
    assert_eq!(got, want);

    // A reassembly with a value the table does not have is refused by name.
    let mut bad = splits.clone();
    bad[0].corners.as_mut().unwrap().corners[0] = 1 << 30;
    let e = progressive_from_stream(&base, base_corners.as_ref(), &bad).unwrap_err();
    assert_eq!(e.kind, meshlod_service::error::ErrorKind::InvalidArgument);
    assert_eq!(e.field, "splits[0].corners", "{e}");
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_streamed_glb_keeps_its_material_and_joint_numbers() {
    use meshlod_engine::io::{MeshFormat, write_mesh_to};
    use meshlod_engine::mesh::MaterialLibrary;
    let server = TestServer::start(ServerConfig::default()).await;
    let mut client = server.client().await;
    // The sphere's halves drawn with two materials, sent as a GLB.
    let mut mesh = textured_sphere();
    let upper: Vec<bool> = (0..3 * mesh.face_count()).map(|k| mesh.corners.colors().unwrap()[k][0] > 0.5).collect();
    mesh.corners.set_materials(Some(upper.iter().map(|&u| u as u32).collect()));
    let materials = vec![serde_json::json!({ "name": "lower" }), serde_json::json!({ "name": "upper" })];
    mesh.corners.library = Some(std::sync::Arc::new(MaterialLibrary { materials, ..Default::default() }));
    let mut glb = Vec::new();
    write_mesh_to(&mut glb, &mesh, MeshFormat::Gltf).unwrap();
    let mut glb_request = request(&mesh);
    glb_request.input = Some(proto::MeshInput {
        source: Some(proto::mesh_input::Source::File(proto::EncodedMesh {
            data: glb,
            format: proto::MeshFormat::Gltf as i32,
        })),
    });
    let pm = stream_of(&mut client, glb_request).await;
    for level in [0, pm.levels()] {
        let m = pm.at_level(level);
        m.check().unwrap_or_else(|e| panic!("level {level}: {e}"));
        assert!(m.corners.names().contains(&"material"), "level {level}");
    }
    let full = pm.at_level(pm.levels());
    let count = |m: &Mesh, which: u32| m.corners.materials().unwrap().iter().filter(|&&x| x == which).count();
    assert_eq!((count(&full, 0), count(&full, 1)), (count(&mesh, 0), count(&mesh, 1)));

    // A skinned GLB (the fuzz corpus' strip): its joints and weights come through the stream.
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../engine/tests/fuzz-corpus/skinned.glb");
    let skinned = meshlod_engine::io::read_mesh(&path).unwrap();
    let mut skinned_request = request(&skinned);
    skinned_request.input = Some(proto::MeshInput {
        source: Some(proto::mesh_input::Source::File(proto::EncodedMesh {
            data: std::fs::read(&path).unwrap(),
            format: proto::MeshFormat::Gltf as i32,
        })),
    });
    let pm = stream_of(&mut client, skinned_request).await;
    let full = pm.at_level(pm.levels());
    full.check().unwrap();
    // Each corner's joints and weights (as bits), sorted: the same skins, in any order.
    let skins = |m: &Mesh| {
        let (joints, weights) = (m.corners.joints().unwrap().clone(), m.corners.weights().unwrap().clone());
        let mut all: Vec<_> = joints.into_iter().zip(weights).map(|(j, w)| (j, w.map(f32::to_bits))).collect();
        all.sort();
        all
    };
    assert_eq!(skins(&full), skins(&skinned));
    server.stop().await;
}

/// Runs SimplifyStream and reassembles what it sends.
async fn stream_of(
    client: &mut proto::mesh_lod_client::MeshLodClient<tonic::transport::Channel>,
    request: proto::SimplifyRequest,
) -> meshlod_engine::pm::ProgressiveMesh {
    let mut stream = client.simplify_stream(request).await.unwrap().into_inner();
    let (mut base, mut base_corners, mut splits) = (None, None, Vec::new());
    while let Some(message) = stream.message().await.unwrap() {
        use proto::simplify_stream_message::Item;
        match message.item.unwrap() {
            Item::Base(b) => base = Some(b),
            Item::BaseCorners(c) => base_corners = Some(c),
            Item::Splits(batch) => splits.extend(batch.splits),
            Item::Stats(_) => {}
        }
    }
    progressive_from_stream(&base.unwrap(), base_corners.as_ref(), &splits).unwrap()
}
