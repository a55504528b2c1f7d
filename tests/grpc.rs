//! End-to-end tests of the gRPC service over real loopback TCP: every RPC, the streamed
//! progressive mesh, field-level errors, cancellation, health, reflection, bearer tokens
//! (admission limits: `admission.rs`).

mod common;

use std::time::{Duration, Instant};

use common::in_flight;
use common::loopback::{TestServer, channel, input, simplify_request};
use meshlod_engine::pm::ProgressiveMesh;
use meshlod_engine::simplify::{SimplifyOptions, simplify};
use meshlod_engine::{Mesh, procedural};
use meshlod_service::convert::{MeshLimits, mesh_from_proto, mesh_to_proto, progressive_from_proto};
use meshlod_service::proto;
use meshlod_service::proto::mesh_lod_client::MeshLodClient;
use meshlod_service::server::ServerConfig;
use tonic::Code;

fn blob() -> Mesh {
    procedural::bumpy_blob(40, 80, 3)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_rpc_over_loopback() {
    let predictor = std::sync::Arc::new(meshlod_service::predict::load(None).unwrap());
    let server = TestServer::start(ServerConfig { predictor: Some(predictor), ..Default::default() }).await;
    let mut client = server.client().await;
    let mesh = blob();

    // Simplify, with the progressive mesh and the Hausdorff figures.
    let mut request = simplify_request(&mesh, 0.9);
    let options = request.options.as_mut().unwrap();
    options.return_progressive = true;
    options.compute_hausdorff = true;
    let response = client.simplify(request).await.unwrap().into_inner();
    let stats = response.stats.unwrap();
    assert_eq!(stats.stop_reason, "target_reached");
    assert_eq!(stats.w_source, proto::WSource::Given as i32);
    let h = response.hausdorff.unwrap();
    assert!(h.hausdorff > 0.0 && h.converged);
    // Certified bounds: the lower one is reached, the upper one within the tolerance of it.
    assert!(h.hausdorff_lower <= h.hausdorff && h.hausdorff - h.hausdorff_lower <= h.tolerance * h.hausdorff_lower);
    let out = mesh_from_proto(response.mesh.as_ref().unwrap(), "mesh", &MeshLimits::default()).unwrap();
    assert_eq!(out.face_count() as u32, stats.faces_out);
    let pm = response.progressive.unwrap();
    let pm = progressive_from_proto(pm.base.as_ref().unwrap(), &pm.splits).unwrap();
    assert_eq!(pm.at_level(pm.levels()).face_count(), mesh.face_count());

    // The same result as the engine in process (and so as the CLI, which calls the same engine).
    let local = simplify(&mesh, &SimplifyOptions { target_ratio: Some(0.9), ..Default::default() }).unwrap();
    assert_eq!(local.mesh, out);
    // The refusals by rule, as the engine counts them; a run that stops above its target says
    // what held it (every edge of a tetrahedron leaves two faces at its merged vertex).
    let (p, e) = (stats.refused.unwrap(), local.stats.refused);
    let sent = [p.link, p.too_few_faces, p.normal_change, p.needle, p.fold, p.seam, p.uv_flip];
    let counted = [e.link, e.too_few_faces, e.normal_change, e.needle, e.fold, e.seam, e.uv_flip].map(|n| n as u64);
    assert_eq!((sent, stats.rejected), (counted, counted.iter().sum()));
    let tetra = Mesh::new(
        vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
    )
    .unwrap();
    let held = client.simplify(simplify_request(&tetra, 0.9)).await.unwrap().into_inner().stats.unwrap();
    assert_eq!(held.stop_reason, "no_legal_collapse");
    assert!(held.rejected > 0 && held.refused.unwrap().too_few_faces == held.rejected, "{held:?}");

    // The distance guard travels in the options: the same result as in process, not the unguarded one.
    let mut request = simplify_request(&mesh, 0.9);
    request.options.as_mut().unwrap().guard = Some(1.0);
    let guarded = client.simplify(request).await.unwrap().into_inner();
    assert_eq!(guarded.stats.as_ref().unwrap().guard, 1.0);
    assert_eq!(stats.guard, 0.0);
    let guarded = mesh_from_proto(guarded.mesh.as_ref().unwrap(), "mesh", &MeshLimits::default()).unwrap();
    let local =
        simplify(&mesh, &SimplifyOptions { target_ratio: Some(0.9), guard: 1.0, ..Default::default() }).unwrap();
    assert_eq!(local.mesh, guarded);
    assert_ne!(guarded, out, "the guard changes the collapse order on a bumpy blob");

    // So does the fan-distance term's weight: on by default, 0 gives the paper's cost.
    assert_eq!(stats.distance_term, 1.0);
    let mut request = simplify_request(&mesh, 0.9);
    request.options.as_mut().unwrap().distance_term = Some(0.0);
    let paper = client.simplify(request).await.unwrap().into_inner();
    assert_eq!(paper.stats.as_ref().unwrap().distance_term, 0.0);
    let paper = mesh_from_proto(paper.mesh.as_ref().unwrap(), "mesh", &MeshLimits::default()).unwrap();
    let local = simplify(&mesh, &SimplifyOptions { target_ratio: Some(0.9), distance_term: 0.0, ..Default::default() })
        .unwrap();
    assert_eq!(local.mesh, paper);
    assert_ne!(paper, out, "the fan-distance term changes the collapse order on a bumpy blob");

    // The same request uploaded in small chunks (client streaming) gives the same result.
    let unary = client.simplify(simplify_request(&mesh, 0.8)).await.unwrap().into_inner();
    let whole = mesh_to_proto(&mesh);
    let mut chunks = Vec::new();
    for (i, (p, t)) in whole.positions.chunks(999).zip(whole.indices.chunks(1501)).enumerate() {
        chunks.push(proto::MeshChunk {
            options: (i == 0).then(|| proto::SimplifyOptions { target_ratio: Some(0.8), ..Default::default() }),
            positions: p.to_vec(),
            indices: t.to_vec(),
        });
    }
    let sent_p: usize = chunks.iter().map(|c| c.positions.len()).sum();
    let sent_i: usize = chunks.iter().map(|c| c.indices.len()).sum();
    chunks.push(proto::MeshChunk {
        options: None,
        positions: whole.positions[sent_p..].to_vec(),
        indices: whole.indices[sent_i..].to_vec(),
    });
    let uploaded = client.simplify_upload(tokio_stream::iter(chunks)).await.unwrap().into_inner();
    assert_eq!(uploaded.mesh, unary.mesh);

    // Refine.
    let refined = client
        .refine(proto::RefineRequest { input: input(&mesh), etc: Some(1.0), ..Default::default() })
        .await
        .unwrap()
        .into_inner();
    let rs = refined.stats.unwrap();
    assert_eq!(rs.mode, "subdivide");
    assert!(rs.faces_out > rs.faces_in);

    // Encoded file input.
    let mut obj = Vec::new();
    meshlod_engine::io::write_mesh_to(&mut obj, &mesh, meshlod_engine::io::MeshFormat::Obj).unwrap();
    let from_file = client
        .simplify(proto::SimplifyRequest {
            input: Some(proto::MeshInput {
                source: Some(proto::mesh_input::Source::File(proto::EncodedMesh {
                    data: obj,
                    format: proto::MeshFormat::Obj as i32,
                })),
            }),
            options: Some(proto::SimplifyOptions { target_faces: Some(500), ..Default::default() }),
            ..Default::default()
        })
        .await
        .unwrap()
        .into_inner();
    assert!(from_file.stats.unwrap().faces_out <= 500);

    // Predict from a mesh, and from features alone.
    let predicted = client
        .predict(proto::PredictRequest {
            subject: Some(proto::predict_request::Subject::Input(input(&mesh).unwrap())),
            target_ratio: Some(0.9),
            ..Default::default()
        })
        .await
        .unwrap()
        .into_inner();
    assert!(predicted.classes.contains(&predicted.w));
    assert!((predicted.probabilities.iter().sum::<f32>() - 1.0).abs() < 1e-4);
    assert!(predicted.etc > 0.0 && !predicted.model_version.is_empty());
    let features = meshlod_engine::features::shape_features(&mesh);
    let from_features = client
        .predict(proto::PredictRequest {
            subject: Some(proto::predict_request::Subject::Features(proto::ShapeFeatures {
                values: features.to_vec(),
            })),
            target_faces: Some((mesh.face_count() / 10) as u32),
            target_ratio: Some(0.9),
        })
        .await
        .unwrap()
        .into_inner();
    assert_eq!(from_features.w, predicted.w);
    let bad = client
        .predict(proto::PredictRequest {
            subject: Some(proto::predict_request::Subject::Features(proto::ShapeFeatures { values: vec![1.0; 3] })),
            target_faces: Some(10),
            target_ratio: Some(0.5),
        })
        .await
        .unwrap_err();
    assert!(bad.code() == Code::InvalidArgument && bad.message().starts_with("features.values:"), "{bad:?}");
    let mut nan = vec![1.0; 8];
    nan[3] = f32::NAN;
    let bad = client
        .predict(proto::PredictRequest {
            subject: Some(proto::predict_request::Subject::Features(proto::ShapeFeatures { values: nan })),
            target_faces: Some(10),
            target_ratio: Some(0.5),
        })
        .await
        .unwrap_err();
    assert!(bad.code() == Code::InvalidArgument && bad.message().starts_with("features.values[3]:"), "{bad:?}");

    // w chosen by the predictor.
    let auto = client
        .simplify(proto::SimplifyRequest {
            input: input(&mesh),
            options: Some(proto::SimplifyOptions { target_ratio: Some(0.9), w_auto: true, ..Default::default() }),
            ..Default::default()
        })
        .await
        .unwrap()
        .into_inner()
        .stats
        .unwrap();
    assert_eq!(auto.w_source, proto::WSource::Predicted as i32);
    assert_eq!(auto.w, predicted.w);
    assert_eq!(auto.model_version, predicted.model_version);

    // w measured rather than predicted: each class tried, the lowest Hausdorff kept.
    let searched = client
        .simplify(proto::SimplifyRequest {
            input: input(&mesh),
            options: Some(proto::SimplifyOptions {
                target_ratio: Some(0.9),
                w_search: true,
                compute_hausdorff: true,
                ..Default::default()
            }),
            ..Default::default()
        })
        .await
        .unwrap()
        .into_inner();
    let stats = searched.stats.unwrap();
    assert_eq!(stats.w_source, proto::WSource::Searched as i32);
    assert_eq!(stats.w_candidates.iter().map(|c| c.w).collect::<Vec<_>>(), [0.0, 0.5, 1.0, 1.5, 2.0]);
    let lowest = stats.w_candidates.iter().map(|c| c.hausdorff).fold(f64::INFINITY, f64::min);
    assert_eq!(stats.w_candidates.iter().find(|c| c.w == stats.w).unwrap().hausdorff, lowest);
    assert_eq!(searched.hausdorff.unwrap().hausdorff, lowest);
    let both = client
        .simplify(proto::SimplifyRequest {
            input: input(&mesh),
            options: Some(proto::SimplifyOptions { w_search: true, w_auto: true, ..Default::default() }),
            ..Default::default()
        })
        .await
        .unwrap_err();
    assert!(both.code() == Code::InvalidArgument && both.message().starts_with("options.w_search"), "{both:?}");
    let etc_auto = client
        .refine(proto::RefineRequest {
            input: input(&mesh),
            target_faces: Some(2 * mesh.face_count() as u32),
            etc_auto: true,
            ..Default::default()
        })
        .await
        .unwrap()
        .into_inner();
    assert!(etc_auto.stats.unwrap().faces_out > mesh.face_count() as u32);
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn streamed_progressive_mesh_reassembles_exactly() {
    let config = ServerConfig { stream_message_bytes: 4096, ..Default::default() };
    let server = TestServer::start(config).await;
    let mut client = server.client().await;
    let mesh = blob();
    let mut stream = client.simplify_stream(simplify_request(&mesh, 0.95)).await.unwrap().into_inner();
    let mut base = None;
    let mut splits = Vec::new();
    let mut stats = None;
    let mut batches = 0;
    while let Some(message) = stream.message().await.unwrap() {
        match message.item.unwrap() {
            proto::simplify_stream_message::Item::Base(b) => base = Some(b),
            proto::simplify_stream_message::Item::Splits(batch) => {
                assert_eq!(batch.first as usize, splits.len(), "batches arrive in order");
                assert!(prost::Message::encoded_len(&batch) <= 8192, "batch too large");
                splits.extend(batch.splits);
                batches += 1;
            }
            proto::simplify_stream_message::Item::Stats(s) => stats = Some(s),
            proto::simplify_stream_message::Item::BaseCorners(_) => panic!("values sent for a mesh without any"),
        }
    }
    assert!(batches > 1, "small message size must split the stream");
    let stats = stats.expect("stats come last");
    let pm: ProgressiveMesh = progressive_from_proto(&base.unwrap(), &splits).unwrap();
    assert_eq!(pm.base().face_count() as u32, stats.faces_out);
    // Matches the engine's progressive mesh (as written by `meshlod simplify --pm`) exactly.
    let local =
        simplify(&mesh, &SimplifyOptions { target_ratio: Some(0.95), record_progressive: true, ..Default::default() })
            .unwrap()
            .progressive
            .unwrap();
    assert_eq!(pm.base(), local.base());
    assert_eq!(pm.splits(), local.splits());
    // Fully refined it is the input, bit for bit.
    let full = pm.at_level(pm.levels());
    let map = local.input_vertex().unwrap();
    for (v, p) in full.positions.iter().enumerate() {
        assert_eq!(p.map(f32::to_bits), mesh.positions[map[v] as usize].map(f32::to_bits));
    }
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn encoded_glb_is_read_and_its_attributes_kept() {
    let server = TestServer::start(ServerConfig::default()).await;
    let mut client = server.client().await;
    // Two quads under a mirrored node hierarchy, with texture coordinates (engine/tests/fuzz-corpus).
    let glb = include_bytes!("../engine/tests/fuzz-corpus/quad-nodes.glb").to_vec();
    let mut request = proto::SimplifyRequest {
        input: Some(proto::MeshInput {
            source: Some(proto::mesh_input::Source::File(proto::EncodedMesh {
                data: glb,
                format: proto::MeshFormat::Gltf as i32,
            })),
        }),
        options: Some(proto::SimplifyOptions {
            target_ratio: Some(0.5),
            return_progressive: true,
            ..Default::default()
        }),
        ..Default::default()
    };
    let response = client.simplify(request.clone()).await.expect("a GLB is read").into_inner();
    let stats = response.stats.unwrap();
    assert_eq!(stats.faces_in, 4);
    // The result keeps its texture coordinates, one per vertex; so does the progressive mesh, in
    // the `.pm` file that comes with it (its structured base has positions only, numbered as the
    // splits number them).
    let mesh = response.mesh.unwrap();
    assert_eq!(mesh.uvs.len(), 2 * mesh.positions.len() / 3);
    assert!(stats.warnings.is_empty(), "{:?}", stats.warnings);
    let pm = response.progressive.unwrap();
    let base = pm.base.as_ref().unwrap();
    assert!(base.uvs.is_empty());
    let rebuilt = progressive_from_proto(base, &pm.splits).expect("the splits fit the base");
    let file = meshlod_engine::pm_format::decode(&pm.file, std::path::Path::new("response.pm")).unwrap().0;
    assert!(file.has_attributes());
    assert_eq!(file.levels(), rebuilt.levels());
    let finest = file.at_level(file.levels());
    assert_eq!(finest.face_count(), 4);
    assert_eq!(finest.corners.names(), ["uv", "material"]);
    assert_eq!(u16::from_le_bytes([pm.file[4], pm.file[5]]), 3); // compact, unless lossless is asked for
    request.options.as_mut().unwrap().progressive_lossless = true;
    let bytes = client.simplify(request).await.unwrap().into_inner().progressive.unwrap().file;
    assert_eq!(u16::from_le_bytes([bytes[4], bytes[5]]), 2);
    let exact = meshlod_engine::pm_format::decode(&bytes, std::path::Path::new("exact.pm")).unwrap().0;
    assert_eq!(exact.at_faces(usize::MAX).triangles, finest.triangles);
    // A GLB whose buffer lives in another file cannot be read from a request.
    let gltf =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../engine/tests/fuzz-corpus/quad-nodes.gltf"))
            .unwrap();
    let start = gltf.find("data:").unwrap();
    let end = start + gltf[start..].find('"').unwrap();
    let outside = format!("{}outside.bin{}", &gltf[..start], &gltf[end..]);
    let status = client
        .simplify(proto::SimplifyRequest {
            input: Some(proto::MeshInput {
                source: Some(proto::mesh_input::Source::File(proto::EncodedMesh {
                    data: outside.into_bytes(),
                    format: proto::MeshFormat::Gltf as i32,
                })),
            }),
            options: None,
            ..Default::default()
        })
        .await
        .unwrap_err();
    assert_eq!(status.code(), tonic::Code::InvalidArgument);
    assert!(status.message().contains("cannot be read here"), "{}", status.message());

    // The result asked for as a file: a GLB back (and no `mesh`), read as the same result; a
    // read-only format is refused by field before any work.
    let glb = include_bytes!("../engine/tests/fuzz-corpus/quad-nodes.glb").to_vec();
    let ask = |format: proto::MeshFormat, quantize_output: bool| proto::SimplifyRequest {
        input: Some(proto::MeshInput {
            source: Some(proto::mesh_input::Source::File(proto::EncodedMesh {
                data: glb.clone(),
                format: proto::MeshFormat::Gltf as i32,
            })),
        }),
        options: Some(proto::SimplifyOptions { target_ratio: Some(0.5), ..Default::default() }),
        output_format: format as i32,
        quantize_output,
    };
    let response = client.simplify(ask(proto::MeshFormat::Gltf, false)).await.unwrap().into_inner();
    assert!(response.mesh.is_none());
    let encoded = response.encoded.expect("the result as a file");
    assert_eq!(encoded.format, proto::MeshFormat::Gltf as i32);
    assert!(encoded.data.starts_with(b"glTF"));
    let back = meshlod_engine::io::read_mesh_bytes(
        &encoded.data,
        None,
        std::path::Path::new("back.glb"),
        &meshlod_engine::io::ReadLimits::default(),
    )
    .unwrap();
    assert_eq!(back.face_count() as u32, response.stats.unwrap().faces_out);
    assert_eq!(back.corners.names(), ["uv", "material"]);
    // Quantized (KHR_mesh_quantization; a quad: the JSON outweighs what it saves), read back as
    // the same faces; GLB only.
    let quantized = client.simplify(ask(proto::MeshFormat::Gltf, true)).await.unwrap().into_inner().encoded.unwrap();
    assert!(quantized.data != encoded.data && quantized.data.windows(21).any(|w| w == b"KHR_mesh_quantization"));
    let path = std::path::Path::new("q.glb");
    let limits = meshlod_engine::io::ReadLimits::default();
    assert_eq!(
        meshlod_engine::io::read_mesh_bytes(&quantized.data, None, path, &limits).unwrap().face_count(),
        back.face_count()
    );
    let status = client.simplify(ask(proto::MeshFormat::Obj, true)).await.unwrap_err();
    assert!(
        status.code() == tonic::Code::InvalidArgument && status.message().contains("quantize_output"),
        "{status:?}"
    );
    let status = client.simplify(ask(proto::MeshFormat::Stl, false)).await.unwrap_err();
    assert_eq!(status.code(), tonic::Code::InvalidArgument);
    assert!(
        status.message().contains("output_format") && status.message().contains("read only"),
        "{}",
        status.message()
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn invalid_requests_name_the_field() {
    let server = TestServer::start(ServerConfig {
        limits: MeshLimits { max_faces: 5000, max_vertices: 5000 },
        ..Default::default()
    })
    .await;
    let mut client = server.client().await;
    let tri = |positions: Vec<f32>, indices: Vec<u32>| proto::SimplifyRequest {
        input: Some(proto::MeshInput {
            source: Some(proto::mesh_input::Source::Mesh(proto::Mesh { positions, indices, ..Default::default() })),
        }),
        options: None,
        ..Default::default()
    };
    let attributed = |uvs: Vec<f32>, normals: Vec<f32>, colors: Vec<f32>| proto::SimplifyRequest {
        input: Some(proto::MeshInput {
            source: Some(proto::mesh_input::Source::Mesh(proto::Mesh {
                positions: vec![0., 0., 0., 1., 0., 0., 0., 1., 0.],
                indices: vec![0, 1, 2],
                uvs,
                normals,
                colors,
            })),
        }),
        options: None,
        ..Default::default()
    };
    let cases: Vec<(proto::SimplifyRequest, &str)> = vec![
        (tri(vec![0., 0., 0., 1., 0., 0., 0., f32::NAN, 0.], vec![0, 1, 2]), "input.mesh.positions[7]"),
        (tri(vec![0., 0., 0., 1., 0., 0., 0., 1., 0.], vec![0, 1, 3]), "input.mesh.indices[2]"),
        (tri(vec![0., 0., 0., 1., 0., 0., 0., 1.], vec![0, 1, 2]), "input.mesh.positions"),
        (tri(vec![], vec![]), "input.mesh.indices"),
        (attributed(vec![0.5; 5], vec![], vec![]), "input.mesh.uvs"),
        (attributed(vec![], vec![0.0, 0.0, 1.0, f32::NAN, 0.0, 1.0, 0.0, 0.0, 1.0], vec![]), "input.mesh.normals[3]"),
        (attributed(vec![], vec![], vec![1.0; 8]), "input.mesh.colors"),
        (proto::SimplifyRequest { input: None, options: None, ..Default::default() }, "input"),
        (
            proto::SimplifyRequest {
                options: Some(proto::SimplifyOptions { target_ratio: Some(1.5), ..Default::default() }),
                ..simplify_request(&procedural::icosphere(2), 0.5)
            },
            "options.target_ratio",
        ),
        (
            proto::SimplifyRequest {
                options: Some(proto::SimplifyOptions { w: Some(7.0), ..Default::default() }),
                ..simplify_request(&procedural::icosphere(2), 0.5)
            },
            "options.w",
        ),
        (
            proto::SimplifyRequest {
                options: Some(proto::SimplifyOptions { guard: Some(-1.0), ..Default::default() }),
                ..simplify_request(&procedural::icosphere(2), 0.5)
            },
            "options.guard",
        ),
        (
            proto::SimplifyRequest {
                options: Some(proto::SimplifyOptions { distance_term: Some(f64::INFINITY), ..Default::default() }),
                ..simplify_request(&procedural::icosphere(2), 0.5)
            },
            "options.distance_term",
        ),
        (
            proto::SimplifyRequest {
                options: Some(proto::SimplifyOptions {
                    guard: Some(1.0),
                    metric: proto::Metric::Melax as i32,
                    ..Default::default()
                }),
                ..simplify_request(&procedural::icosphere(2), 0.5)
            },
            "options.guard",
        ),
        (
            proto::SimplifyRequest {
                options: Some(proto::SimplifyOptions { max_normal_change_degrees: Some(0.0), ..Default::default() }),
                ..simplify_request(&procedural::icosphere(2), 0.5)
            },
            "options.max_normal_change_degrees",
        ),
        (
            proto::SimplifyRequest {
                options: Some(proto::SimplifyOptions { prune: true, return_progressive: true, ..Default::default() }),
                ..simplify_request(&procedural::icosphere(2), 0.5)
            },
            "options.prune",
        ),
        (
            proto::SimplifyRequest {
                options: Some(proto::SimplifyOptions { metric: 42, ..Default::default() }),
                ..simplify_request(&procedural::icosphere(2), 0.5)
            },
            "options.metric",
        ),
        (simplify_request(&procedural::icosphere(4), 0.5), "input.mesh"),
    ];
    // The path before the first ": " is exactly the request field, as the proto spells it.
    let path = |s: &tonic::Status| s.message().split_once(": ").map(|(p, _)| p.to_string()).unwrap_or_default();
    for (request, field) in cases {
        let status = client.simplify(request).await.unwrap_err();
        assert_eq!(status.code(), Code::InvalidArgument, "{field}: {status:?}");
        assert_eq!(path(&status), field, "message '{}'", status.message());
    }
    let refine_with = |r: proto::RefineRequest| proto::RefineRequest { input: input(&procedural::icosphere(1)), ..r };
    let refine_cases = vec![
        (refine_with(proto::RefineRequest { etc: Some(-1.0), ..Default::default() }), "etc"),
        (refine_with(proto::RefineRequest { etc: Some(1.0), rounds: Some(0), ..Default::default() }), "rounds"),
        (refine_with(proto::RefineRequest { target_faces: Some(0), mode: 1, ..Default::default() }), "target_faces"),
        (refine_with(proto::RefineRequest { etc: Some(1.0), mode: 9, ..Default::default() }), "mode"),
        (refine_with(proto::RefineRequest { etc: Some(1.0), target_faces: Some(10), ..Default::default() }), "etc"),
    ];
    for (request, field) in refine_cases {
        let status = client.refine(request).await.unwrap_err();
        assert_eq!(status.code(), Code::InvalidArgument, "{field}: {status:?}");
        assert_eq!(path(&status), field, "message '{}'", status.message());
    }
    let bad_file = proto::SimplifyRequest {
        input: Some(proto::MeshInput {
            source: Some(proto::mesh_input::Source::File(proto::EncodedMesh {
                data: b"v 0 0 0\nv 1 0 0\nf 1 2 9\n".to_vec(),
                format: proto::MeshFormat::Obj as i32,
            })),
        }),
        options: None,
        ..Default::default()
    };
    let status = client.simplify(bad_file).await.unwrap_err();
    assert_eq!(status.code(), Code::InvalidArgument);
    assert!(status.message().starts_with("input.file") && status.message().contains("line 3"), "{}", status.message());
    let too_big =
        (0..20).map(|_| proto::MeshChunk { options: None, positions: vec![0.0; 3 * 400], indices: vec![0; 3 * 400] });
    let status = client.simplify_upload(tokio_stream::iter(too_big)).await.unwrap_err();
    assert!(status.code() == Code::InvalidArgument && status.message().contains("mesh too large"), "{status:?}");
    let refine = client
        .refine(proto::RefineRequest {
            input: input(&procedural::icosphere(1)),
            etc: Some(1.0),
            rounds: Some(9),
            ..Default::default()
        })
        .await
        .unwrap_err();
    assert_eq!(refine.code(), Code::InvalidArgument);
    assert!(refine.message().contains("rounds"), "{}", refine.message());
    // The server is still healthy after all of that.
    assert!(client.simplify(simplify_request(&procedural::icosphere(2), 0.5)).await.is_ok());
    server.stop().await;
}

/// Sends raw bytes as a Simplify request body.
#[derive(Clone, Default)]
struct RawCodec;

impl tonic::codec::Codec for RawCodec {
    type Encode = Vec<u8>;
    type Decode = Vec<u8>;
    type Encoder = RawCodec;
    type Decoder = RawCodec;
    fn encoder(&mut self) -> RawCodec {
        RawCodec
    }
    fn decoder(&mut self) -> RawCodec {
        RawCodec
    }
}

impl tonic::codec::Encoder for RawCodec {
    type Item = Vec<u8>;
    type Error = tonic::Status;
    fn encode(&mut self, item: Vec<u8>, dst: &mut tonic::codec::EncodeBuf<'_>) -> Result<(), tonic::Status> {
        use bytes::BufMut;
        dst.put_slice(&item);
        Ok(())
    }
}

impl tonic::codec::Decoder for RawCodec {
    type Item = Vec<u8>;
    type Error = tonic::Status;
    fn decode(&mut self, src: &mut tonic::codec::DecodeBuf<'_>) -> Result<Option<Vec<u8>>, tonic::Status> {
        use bytes::Buf;
        let mut out = vec![0; src.remaining()];
        src.copy_to_slice(&mut out);
        Ok(Some(out))
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn codec_errors_get_the_contracts_codes() {
    let server = TestServer::start(ServerConfig { max_message_bytes: 64 << 10, ..Default::default() }).await;
    let mut grpc = tonic::client::Grpc::new(channel(server.addr).await);
    let path = http::uri::PathAndQuery::from_static("/meshlod.v1.MeshLod/Simplify");
    // Not a protobuf message: a field tag of 0 and a truncated varint.
    grpc.ready().await.unwrap();
    let garbage = grpc.unary(tonic::Request::new(vec![0x00, 0xff, 0xff]), path.clone(), RawCodec).await.unwrap_err();
    assert_eq!(garbage.code(), Code::InvalidArgument, "{garbage:?}");
    // Over the message limit: RESOURCE_EXHAUSTED, not OUT_OF_RANGE.
    let mut client = server.client().await;
    let big = client.simplify(simplify_request(&procedural::icosphere(5), 0.5)).await.unwrap_err();
    assert_eq!(big.code(), Code::ResourceExhausted, "{big:?}");
    // The same for an upload whose chunk is over the limit.
    let chunk = proto::MeshChunk { options: None, positions: vec![0.0; 3 * 20_000], indices: vec![0; 3 * 20_000] };
    let big = client.simplify_upload(tokio_stream::iter(vec![chunk])).await.unwrap_err();
    assert_eq!(big.code(), Code::ResourceExhausted, "{big:?}");
    // Valid requests still work.
    assert!(client.simplify(simplify_request(&procedural::icosphere(2), 0.5)).await.is_ok());
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn health_reflection_and_token() {
    let server = TestServer::start(ServerConfig { token: Some("s3cret".into()), ..Default::default() }).await;
    let channel = channel(server.addr).await;
    let mut health = tonic_health::pb::health_client::HealthClient::new(channel.clone());
    let status = health
        .check(tonic_health::pb::HealthCheckRequest { service: "meshlod.v1.MeshLod".into() })
        .await
        .unwrap()
        .into_inner();
    assert_eq!(status.status, tonic_health::pb::health_check_response::ServingStatus::Serving as i32);

    use tonic_reflection::pb::v1::server_reflection_client::ServerReflectionClient;
    use tonic_reflection::pb::v1::server_reflection_request::MessageRequest;
    use tonic_reflection::pb::v1::server_reflection_response::MessageResponse;
    let mut reflection = ServerReflectionClient::new(channel.clone());
    let request = tonic_reflection::pb::v1::ServerReflectionRequest {
        host: String::new(),
        message_request: Some(MessageRequest::ListServices(String::new())),
    };
    let mut responses = reflection.server_reflection_info(tokio_stream::iter([request])).await.unwrap().into_inner();
    let Some(MessageResponse::ListServicesResponse(list)) =
        responses.message().await.unwrap().unwrap().message_response
    else {
        panic!("no service list");
    };
    let names: Vec<String> = list.service.into_iter().map(|s| s.name).collect();
    assert!(names.contains(&"meshlod.v1.MeshLod".to_string()), "{names:?}");

    let mut client = MeshLodClient::new(channel);
    let denied = client.simplify(simplify_request(&procedural::icosphere(2), 0.5)).await.unwrap_err();
    // Without a model, Predict says so instead of guessing.
    let mut predict = tonic::Request::new(proto::PredictRequest {
        subject: Some(proto::predict_request::Subject::Input(input(&procedural::icosphere(1)).unwrap())),
        target_ratio: Some(0.5),
        ..Default::default()
    });
    predict.metadata_mut().insert("authorization", "Bearer s3cret".parse().unwrap());
    assert_eq!(client.predict(predict).await.unwrap_err().code(), Code::FailedPrecondition);
    assert_eq!(denied.code(), Code::Unauthenticated);
    let mut request = tonic::Request::new(simplify_request(&procedural::icosphere(2), 0.5));
    request.metadata_mut().insert("authorization", "Bearer s3cret".parse().unwrap());
    assert!(client.simplify(request).await.is_ok());
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn hausdorff_rpc_brackets_refuses_and_cancels() {
    let metrics_port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap();
    let server = TestServer::start(ServerConfig { metrics_listen: Some(metrics_port), ..Default::default() }).await;
    let metrics = server.metrics.unwrap();
    let mut client = server.client().await;
    let mesh = blob();
    let coarse = simplify(&mesh, &SimplifyOptions { target_ratio: Some(0.9), ..Default::default() }).unwrap().mesh;
    let request =
        |a: &Mesh, b: &Mesh| proto::HausdorffRequest { a: input(a), b: input(b), tolerance: None, samples: None };
    // The same figures as the engine's, bounds within the default tolerance.
    let report = client.hausdorff(request(&mesh, &coarse)).await.unwrap().into_inner();
    let local = meshlod_engine::hausdorff::hausdorff(&mesh, &coarse, &Default::default()).unwrap();
    assert_eq!((report.hausdorff, report.hausdorff_lower), (local.hausdorff, local.hausdorff_lower));
    assert!(report.converged && report.hausdorff - report.hausdorff_lower <= 1e-3 * report.hausdorff_lower);

    // Field paths, exactly.
    let refused = |status: tonic::Status| (status.code(), status.message().split(':').next().unwrap().to_string());
    let bad_tolerance = proto::HausdorffRequest { tolerance: Some(0.0), ..request(&mesh, &coarse) };
    let status = client.hausdorff(bad_tolerance).await.unwrap_err();
    assert_eq!(refused(status), (Code::InvalidArgument, "tolerance".to_string()));
    let missing = proto::HausdorffRequest { b: None, ..request(&mesh, &coarse) };
    assert_eq!(refused(client.hausdorff(missing).await.unwrap_err()), (Code::InvalidArgument, "b".to_string()));
    let flat = Mesh::new(vec![[0., 0., 0.], [1., 0., 0.], [2., 0., 0.]], vec![[0, 1, 2]]).unwrap();
    let status = client.hausdorff(request(&mesh, &flat)).await.unwrap_err();
    assert_eq!(refused(status), (Code::InvalidArgument, "b".to_string()));

    // A large pair under a short deadline: the call fails and the worker stops.
    let (big, other) = (procedural::bumpy_blob(300, 600, 5), procedural::bumpy_blob(200, 400, 6));
    let mut call = tonic::Request::new(request(&big, &other));
    call.set_timeout(Duration::from_millis(300));
    let code = client.hausdorff(call).await.unwrap_err().code();
    assert!(matches!(code, Code::Cancelled | Code::DeadlineExceeded), "{code:?}");
    let stopped = Instant::now();
    while in_flight(metrics) != 0 {
        assert!(stopped.elapsed() < Duration::from_secs(3), "cancelled measurement kept running");
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    server.stop().await;
}
