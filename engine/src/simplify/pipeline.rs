//! The whole run, in the order of the module documentation: options and input checked, the
//! mesh prepared, in halves first where that applies, then one sequence of collapses, and the
//! outputs built.

use std::time::Instant;

use super::halves;
use super::kernel::State;
use super::options::{Metric, Outcome, Placement, Simplified, SimplifyOptions, SimplifyStats};
use super::{classify, flat, guard, prune, run, sheets};
use crate::error::MeshError;
use crate::mesh::{DistanceUnits, Mesh};
use crate::pm::ProgressiveMesh;

/// Simplifies `mesh` by edge collapses until a target is met; see the module documentation.
pub fn simplify(mesh: &Mesh, options: &SimplifyOptions) -> Result<Simplified, MeshError> {
    let started = Instant::now();
    // 1. Options and input.
    options.validate()?;
    mesh.check()?;
    // A flat-shaded mesh goes without its normals, and gets its faces' again at the end (`flat`).
    let flat_normals = flat::is_flat_shaded(mesh);
    let unshaded;
    let mesh = if flat_normals {
        unshaded = flat::without_normals(mesh);
        &unshaded
    } else {
        mesh
    };
    let (prepared, input_vertex, dropped) = classify::prepare_in_place(mesh);
    if prepared.triangles.is_empty() {
        return Err(MeshError::Empty { what: "no faces" });
    }
    let faces_in = prepared.face_count();
    let target = options.face_target(faces_in);
    if (options.guard > 0.0 || options.distance_term > 0.0) && prepared.vertex_count() >= guard::GUARDED as usize {
        return Err(MeshError::InvalidParameter {
            name: if options.guard > 0.0 { "guard" } else { "distance_term" },
            reason: format!("{} vertices: the distance terms handle fewer than 2³¹", prepared.vertex_count()),
        });
    }
    // Every vertex of the prepared mesh is on a face: its bounds are its surface's.
    let units = DistanceUnits::new(&prepared.bounds().expect("has faces"));
    // `Auto` placement, resolved for this mesh.
    let resolved;
    let options = if options.placement == Placement::Auto {
        resolved = SimplifyOptions { placement: options.placement.resolve(&prepared), ..options.clone() };
        &resolved
    } else {
        options
    };
    // A large mesh goes in halves first, where its options allow (`halves`); else (or where a
    // half has stacked faces) one sequence over the whole mesh.
    let halved = if halves::applies(&prepared, options, target) {
        halves::simplify(&prepared, &input_vertex, options, &units, target)?
    } else {
        None
    };
    let mut out = match halved {
        Some(out) => out,
        None => one_sequence(&prepared, &input_vertex, options, &units, target)?,
    };
    if flat_normals {
        flat::with_flat_normals(&mut out.mesh);
    }
    let stats = SimplifyStats {
        faces_in,
        faces_out: out.mesh.face_count(),
        vertices_in: prepared.vertex_count(),
        vertices_out: out.mesh.vertex_count(),
        target_faces: target,
        placement: options.placement,
        collapses: out.collapses,
        stop_reason: out.stop_reason,
        max_collapse_error: out.max_collapse_error,
        rejected: out.refused.total(),
        refused: out.refused,
        frozen_vertices: out.frozen_vertices,
        holes_closed: out.holes_closed,
        parts_removed: out.parts_removed,
        dropped_degenerate_faces: dropped,
        dropped_duplicate_faces: out.dropped_duplicate_faces,
        back_faces: out.back_faces,
        halves: out.halves,
        distance_term: out.distance_term,
        flat_normals,
        seconds: started.elapsed().as_secs_f64(),
    };
    Ok(Simplified { mesh: out.mesh, progressive: out.progressive, stats })
}

/// Steps 2–6 of the module doc as one sequence of collapses over the whole of `prepared`.
fn one_sequence(
    prepared: &Mesh,
    input_vertex: &[u32],
    options: &SimplifyOptions,
    units: &DistanceUnits,
    target: usize,
) -> Result<Outcome, MeshError> {
    let faces_in = prepared.face_count();
    let prepared = std::borrow::Cow::Borrowed(prepared);
    // 2–3. Classification and working state. Melax's cost reads face normals through the triangle
    // array; the quadric costs never do, so the array is rebuilt once at the end instead.
    let track = options.metric == Metric::Melax;
    let (mut state, mut edges) = State::with_tracking(&prepared, options, track);
    // Faces stacked on another (copies, back-to-back twins) freeze their vertices: set aside, and
    // the state made again for the one sheet (`sheets`).
    let stacked = state.stacked_faces(&prepared);
    let (prepared, set_aside) = if stacked.is_empty() {
        (prepared, sheets::Stacked::default())
    } else {
        let (sheet, set_aside) = sheets::one_sided(&prepared, &stacked);
        (state, edges) = State::with_tracking(&sheet, options, track);
        (std::borrow::Cow::Owned(sheet), set_aside)
    };
    // A face with a back set aside counts twice towards the target: the output has both.
    state.backs = set_aside.backs;
    let sheet_faces = prepared.face_count();
    let output_faces = sheet_faces + set_aside.twins;
    state.carry_attributes(&prepared);
    // 4. Every edge queued.
    let heap = run::initial_queue(&state, edges, sheet_faces);
    // 5. The loop (with the parts it may take out whole, when asked to).
    let parts = options.prune.then(|| prune::Parts::new(&prepared, units)).flatten();
    let mut run = run::run(&mut state, heap, parts, units, output_faces, target)?;
    let collapses = run.log.len();
    let holes_closed = run.log.iter().filter(|r| r.hole != crate::pm::NO_VERTEX).count();
    // 6. Outputs. The guard's tree and tables are done with: their memory goes back first.
    state.terms.guard = None;
    state.rebuild_triangles(&prepared, &run.log);
    // The output mesh and the progressive mesh read the state only: built side by side where the
    // pool has threads for them.
    let (simplified, progressive) = crate::parallel::join(
        faces_in,
        || {
            let out = state.output_mesh();
            let live = (0..state.topo.face_alive.len()).filter(|&f| state.topo.face_alive[f]);
            sheets::with_backs(out, live, &state.backs)
        },
        || {
            options.record_progressive.then(|| {
                ProgressiveMesh::from_log(
                    &prepared,
                    input_vertex,
                    |v| state.vertices[v as usize].position,
                    &state.topo.triangles,
                    &state.topo.face_alive,
                    std::mem::take(&mut run.log),
                    (!state.seams.corner_source.is_empty()).then(|| crate::pm::AttributeLog {
                        values: &state.seams.attributes,
                        corner_source: &state.seams.corner_source,
                        journal: &state.seams.journal,
                        journal_ends: &state.seams.journal_ends,
                    }),
                )
            })
        },
    );
    Ok(Outcome {
        mesh: simplified,
        progressive,
        collapses,
        holes_closed,
        stop_reason: run.stop_reason,
        max_collapse_error: run.max_collapse_error,
        refused: run.refused,
        frozen_vertices: state.frozen_vertices(),
        parts_removed: run.parts_removed,
        dropped_duplicate_faces: set_aside.copies,
        back_faces: set_aside.twins,
        halves: false,
        distance_term: state.terms.fan_term,
    })
}
