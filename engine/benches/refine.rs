//! Refinement benchmark, one thread: adaptive and uniform modified butterfly (output triangles per
//! second), and energy-driven triangle collapse beside the edge-collapse simplifier removing the
//! same number of faces. One standard line per case.
//!
//! Run: `cargo bench -p meshlod-engine --bench refine` (needs the shared meshes).

// The peak-tracking allocator needs `unsafe` (GlobalAlloc); benches only.
#[allow(unsafe_code, dead_code)]
#[path = "support/mod.rs"]
mod support;

use meshlod_engine::io::read_mesh;
use meshlod_engine::refine::{RefineMode, RefineOptions, refine, subdivide_uniform};
use meshlod_engine::simplify::{SimplifyOptions, prepare, simplify};
use support::{PeakAlloc, best_of};

#[global_allocator]
static ALLOC: PeakAlloc = PeakAlloc;

fn main() {
    rayon::ThreadPoolBuilder::new().num_threads(1).build_global().ok();
    let Some(dir) = meshlod_engine::datasets::shared_meshes_dir() else {
        eprintln!("!!! shared meshes not found (set MESHLOD_MESHES) !!!");
        std::process::exit(1);
    };
    for name in ["stanford-bunny", "nefertiti"] {
        let mesh = prepare(&read_mesh(dir.join(format!("{name}.obj"))).expect("reads")).0;
        let faces = mesh.face_count();
        let (uniform, t_uniform) = best_of(3, || subdivide_uniform(&mesh));
        println!(
            "{name} uniform butterfly: {faces} → {} triangles, time {:.1} ms, {:.2} M output tri/s",
            uniform.face_count(),
            t_uniform * 1e3,
            uniform.face_count() as f64 / t_uniform / 1e6
        );
        for etc in [0.9, 1.4] {
            let options = RefineOptions { etc: Some(etc), mode: RefineMode::Subdivide, ..Default::default() };
            let (r, t) = best_of(3, || refine(&mesh, &options).expect("refines"));
            println!(
                "{name} adaptive butterfly ETC {etc}: {faces} → {} triangles, time {:.1} ms (energies included), {:.2} M output tri/s",
                r.mesh.face_count(),
                t * 1e3,
                r.mesh.face_count() as f64 / t / 1e6
            );
        }
        let options = RefineOptions { etc: Some(1.4), mode: RefineMode::Simplify, ..Default::default() };
        let (coarse, t_tri) = best_of(3, || refine(&mesh, &options).expect("coarsens"));
        let target = coarse.mesh.face_count();
        let edge_options = SimplifyOptions { target_faces: Some(target), target_ratio: None, ..Default::default() };
        let (edge, t_edge) = best_of(3, || simplify(&mesh, &edge_options).expect("simplifies"));
        println!(
            "{name} triangle collapse ETC 1.4: {faces} → {target} triangles, time {:.1} ms, peer (edge collapse, QEM) {} triangles {:.1} ms, ratio {:.2}",
            t_tri * 1e3,
            edge.mesh.face_count(),
            t_edge * 1e3,
            t_tri / t_edge
        );
    }
}
