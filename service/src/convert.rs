//! Conversions between the gRPC contract and the engine, with field-level validation.
//!
//! Every refusal is `INVALID_ARGUMENT` whose message starts with the field path, so a client can
//! point at the exact value: `input.mesh.indices[7]: vertex 912 out of range (300 vertices)`.

use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use meshlod_engine::io::{MeshFormat, ReadLimits, WriteOptions, read_mesh_bytes};
use meshlod_engine::pm::{Hole, NO_VERTEX, ProgressiveMesh, StreamedSplit, VertexSplit};
use meshlod_engine::refine::RefineMode;
use meshlod_engine::simplify::{BoundaryMode, Metric, NormalUpdate, Placement, SimplifyOptions};
use meshlod_engine::{Mesh, MeshError};
use tonic::Status;

use crate::error::{ErrorKind, JobError};
use crate::request::{EtcChoice, RefineRequest, SimplifyRequest, WChoice};

use crate::proto;

/// Size limits applied to every mesh a request carries.
#[derive(Debug, Clone, Copy)]
pub struct MeshLimits {
    /// Largest number of faces accepted.
    pub max_faces: usize,
    /// Largest number of vertices accepted.
    pub max_vertices: usize,
}

impl MeshLimits {
    /// Limits from a face count alone (`--max-faces`): vertices up to three per face, which no
    /// mesh without unused vertices exceeds, so the face limit is the one a user meets.
    pub fn for_faces(max_faces: usize) -> MeshLimits {
        MeshLimits { max_faces, max_vertices: max_faces.saturating_mul(3) }
    }
}

impl Default for MeshLimits {
    /// 10 million faces and vertices: well above the 2-million-triangle meshes the service is
    /// sized for, well below what exhausts a pod's memory.
    fn default() -> Self {
        MeshLimits { max_faces: 10_000_000, max_vertices: 10_000_000 }
    }
}

fn invalid(field: impl AsRef<str>, message: impl AsRef<str>) -> JobError {
    JobError::invalid(field.as_ref(), message.as_ref())
}

/// A job's error as a gRPC status, whose message starts with the field at fault: the one place
/// the service's errors meet the transport.
impl From<JobError> for Status {
    fn from(e: JobError) -> Status {
        let message = e.to_string();
        match e.kind {
            ErrorKind::InvalidArgument => Status::invalid_argument(message),
            ErrorKind::FailedPrecondition => Status::failed_precondition(message),
            ErrorKind::Cancelled => Status::cancelled(message),
            ErrorKind::Internal => Status::internal(message),
        }
    }
}

/// A server's status as the job error it stands for: the field read back from the start of its
/// message where it names one (the contract's form, `field: reason`).
pub fn error_from_status(status: &Status) -> JobError {
    let kind = match status.code() {
        tonic::Code::InvalidArgument => ErrorKind::InvalidArgument,
        tonic::Code::FailedPrecondition => ErrorKind::FailedPrecondition,
        tonic::Code::Cancelled => ErrorKind::Cancelled,
        _ => ErrorKind::Internal,
    };
    let message = status.message();
    let named = message.split_once(": ").filter(|(field, _)| !field.is_empty() && !field.contains(' '));
    match named {
        Some((field, reason)) => JobError { field: field.into(), kind, reason: reason.into() },
        None => JobError { field: String::new(), kind, reason: format!("{message} ({:?})", status.code()) },
    }
}

/// An engine error as a job error, naming the request field it concerns: a parameter error names
/// `options_field.name`, or `name` alone when `options_field` is empty.
pub fn engine_error(error: MeshError, options_field: &str) -> JobError {
    match error {
        MeshError::Cancelled => JobError::cancelled(),
        MeshError::InvalidParameter { name, reason } if options_field.is_empty() => invalid(name, reason),
        MeshError::InvalidParameter { name, reason } => invalid(format!("{options_field}.{name}"), reason),
        MeshError::TooLarge { .. } => invalid("input", error.to_string()),
        MeshError::Empty { .. }
        | MeshError::NonFiniteCoordinate { .. }
        | MeshError::IndexOutOfRange { .. }
        | MeshError::Parse { .. }
        | MeshError::UnsupportedFormat { .. } => invalid("input", error.to_string()),
        MeshError::Io { .. } => JobError::internal(error.to_string()),
    }
}

/// Reads the mesh of a request, checking sizes, indices and coordinates; an encoded file's read
/// stops when `cancel` is raised.
pub fn mesh_from_input(
    input: Option<&proto::MeshInput>,
    field: &str,
    limits: &MeshLimits,
    cancel: Option<Arc<AtomicBool>>,
) -> Result<Mesh, JobError> {
    let source =
        input.and_then(|i| i.source.as_ref()).ok_or_else(|| invalid(field, "missing: give a mesh or a file"))?;
    match source {
        proto::mesh_input::Source::Mesh(m) => mesh_from_proto(m, &format!("{field}.mesh"), limits),
        proto::mesh_input::Source::File(file) => {
            let format = match proto::MeshFormat::try_from(file.format) {
                Ok(proto::MeshFormat::Obj) => Some(MeshFormat::Obj),
                Ok(proto::MeshFormat::Ply) => Some(MeshFormat::Ply),
                Ok(proto::MeshFormat::Stl) => Some(MeshFormat::Stl),
                Ok(proto::MeshFormat::Off) => Some(MeshFormat::Off),
                Ok(proto::MeshFormat::Gltf) => Some(MeshFormat::Gltf),
                Ok(proto::MeshFormat::Unspecified) => None,
                Err(_) => {
                    return Err(invalid(format!("{field}.file.format"), format!("unknown format {}", file.format)));
                }
            };
            let read_limits =
                ReadLimits { max_vertices: limits.max_vertices as u64, max_faces: limits.max_faces as u64, cancel };
            let mesh =
                read_mesh_bytes(&file.data, format, Path::new("request"), &read_limits).map_err(|e| match e {
                    MeshError::Cancelled => JobError::cancelled(),
                    e => invalid(format!("{field}.file"), e.to_string()),
                })?;
            if mesh.triangles.is_empty() {
                return Err(invalid(format!("{field}.file"), "the mesh has no faces"));
            }
            Ok(mesh)
        }
    }
}

/// Checks and converts a contract mesh.
pub fn mesh_from_proto(m: &proto::Mesh, field: &str, limits: &MeshLimits) -> Result<Mesh, JobError> {
    if !m.positions.len().is_multiple_of(3) {
        return Err(invalid(
            format!("{field}.positions"),
            format!("length {} is not a multiple of 3", m.positions.len()),
        ));
    }
    if !m.indices.len().is_multiple_of(3) {
        return Err(invalid(format!("{field}.indices"), format!("length {} is not a multiple of 3", m.indices.len())));
    }
    let vertex_count = m.positions.len() / 3;
    let face_count = m.indices.len() / 3;
    if face_count == 0 {
        return Err(invalid(format!("{field}.indices"), "empty: the mesh has no faces"));
    }
    if face_count > limits.max_faces {
        return Err(invalid(
            field,
            format!("mesh too large: {face_count} faces exceeds the limit of {}", limits.max_faces),
        ));
    }
    if vertex_count > limits.max_vertices {
        return Err(invalid(
            field,
            format!(
                "mesh too large: {vertex_count} vertices exceeds the limit of {} (unused vertices count too)",
                limits.max_vertices
            ),
        ));
    }
    if let Some(i) = m.positions.iter().position(|c| !c.is_finite()) {
        return Err(invalid(format!("{field}.positions[{i}]"), format!("{} is not finite", m.positions[i])));
    }
    if let Some(k) = m.indices.iter().position(|&v| v as usize >= vertex_count) {
        return Err(invalid(
            format!("{field}.indices[{k}]"),
            format!("vertex {} out of range ({vertex_count} vertices)", m.indices[k]),
        ));
    }
    let positions = m.positions.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let triangles: Vec<[u32; 3]> = m.indices.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    // Per-vertex attributes become per-corner ones.
    fn per_corner<const N: usize>(
        values: &[f32],
        name: &str,
        vertex_count: usize,
        triangles: &[[u32; 3]],
    ) -> Result<Option<Vec<[f32; N]>>, JobError> {
        if values.is_empty() {
            return Ok(None);
        }
        if values.len() != N * vertex_count {
            return Err(invalid(
                name,
                format!(
                    "length {} is not {N} per vertex ({} for {vertex_count} vertices)",
                    values.len(),
                    N * vertex_count
                ),
            ));
        }
        if let Some(i) = values.iter().position(|c| !c.is_finite()) {
            return Err(invalid(format!("{name}[{i}]"), format!("{} is not finite", values[i])));
        }
        let at = |v: u32| std::array::from_fn(|k| values[N * v as usize + k]);
        Ok(Some(triangles.iter().flatten().map(|&v| at(v)).collect()))
    }
    let mut corners = meshlod_engine::mesh::CornerAttributes::default();
    corners.set_normals(per_corner(&m.normals, &format!("{field}.normals"), vertex_count, &triangles)?);
    corners.set_uvs(per_corner(&m.uvs, &format!("{field}.uvs"), vertex_count, &triangles)?);
    corners.set_colors(per_corner(&m.colors, &format!("{field}.colors"), vertex_count, &triangles)?);
    let mut mesh = Mesh::new(positions, triangles).map_err(|e| invalid(field, e.to_string()))?;
    mesh.corners = corners;
    if !mesh.corners.is_empty() {
        // One value per vertex, as in PLY: a seam arrives as two vertices at one position (as
        // `mesh_to_proto` sends it). Joined back, a seam is a seam, not a cut that the simplifier
        // would treat as two borders and could open.
        mesh.join_cut_seams();
    }
    Ok(mesh)
}

/// The file format a request asks its result in (`None`: as a `Mesh`); read-only formats and
/// unknown values are INVALID_ARGUMENT naming `field`.
pub fn output_format(value: i32, field: &str) -> Result<Option<proto::MeshFormat>, JobError> {
    match proto::MeshFormat::try_from(value) {
        Ok(proto::MeshFormat::Unspecified) => Ok(None),
        Ok(f @ (proto::MeshFormat::Obj | proto::MeshFormat::Ply | proto::MeshFormat::Gltf)) => Ok(Some(f)),
        Ok(f) => Err(invalid(field, format!("{} is read only: ask for OBJ, PLY or GLTF", f.as_str_name()))),
        Err(_) => Err(invalid(field, format!("unknown format {value}"))),
    }
}

/// The write options a request's `quantize_output` asks for, checked against its output format
/// (before any work).
pub fn write_options(quantize: bool, format: Option<proto::MeshFormat>) -> Result<WriteOptions, JobError> {
    if quantize && format != Some(proto::MeshFormat::Gltf) {
        return Err(invalid(
            "quantize_output",
            "KHR_mesh_quantization is a glTF extension: it needs output_format MESH_FORMAT_GLTF",
        ));
    }
    Ok(WriteOptions { quantize })
}

/// The mesh as a file in `format` (glTF as GLB), or `None` when no format was asked for.
pub fn encode_mesh(
    mesh: &Mesh,
    format: Option<proto::MeshFormat>,
    write: &WriteOptions,
) -> Result<Option<proto::EncodedMesh>, JobError> {
    let Some(format) = format else { return Ok(None) };
    let engine_format = match format {
        proto::MeshFormat::Obj => MeshFormat::Obj,
        proto::MeshFormat::Ply => MeshFormat::Ply,
        _ => MeshFormat::Gltf,
    };
    let mut data = Vec::new();
    let written = if engine_format == MeshFormat::Gltf {
        meshlod_engine::io::write_gltf_with(&mut data, mesh, true, None, write)
    } else {
        meshlod_engine::io::write_mesh_to(&mut data, mesh, engine_format)
    };
    written.map_err(|e| {
        invalid("output_format", format!("the result cannot be written as {}: {e}", format.as_str_name()))
    })?;
    Ok(Some(proto::EncodedMesh { data, format: format as i32 }))
}

/// Converts an engine mesh to the contract: attributes per vertex, a vertex whose corners differ
/// (a seam) once per distinct value.
pub fn mesh_to_proto(mesh: &Mesh) -> proto::Mesh {
    let c = &mesh.corners;
    if c.uvs().is_none() && c.normals().is_none() && c.colors().is_none() {
        return proto::Mesh {
            positions: mesh.positions.iter().flatten().copied().collect(),
            indices: mesh.triangles.iter().flatten().copied().collect(),
            ..Default::default()
        };
    }
    // The contract has no materials: vertices are split by their values only.
    let wedges = c.value_wedges(&mesh.triangles, mesh.vertex_count());
    fn flat<const N: usize>(values: Option<&[[f32; N]]>, source: &[usize]) -> Vec<f32> {
        values.map_or_else(Vec::new, |v| source.iter().flat_map(|&k| v[k]).collect())
    }
    proto::Mesh {
        positions: (0..wedges.source.len()).flat_map(|i| mesh.positions[wedges.vertex(&mesh.triangles, i)]).collect(),
        indices: wedges.corner_vertex.clone(),
        normals: flat(c.normals().map(Vec::as_slice), &wedges.source),
        uvs: flat(c.uvs_with_origin(false).as_deref(), &wedges.source),
        colors: flat(c.colors().map(Vec::as_slice), &wedges.source),
    }
}

/// Converts one vertex split to the contract.
pub fn split_to_proto(s: &VertexSplit) -> proto::VertexSplit {
    proto::VertexSplit {
        vs: s.vs,
        vl: (s.vl != NO_VERTEX).then_some(s.vl),
        vr: (s.vr != NO_VERTEX).then_some(s.vr),
        hole: match s.hole {
            Hole::None => proto::Hole::Unspecified,
            Hole::Left => proto::Hole::Left,
            Hole::Right => proto::Hole::Right,
        } as i32,
        position: s.new_position.to_vec(),
        vs_position: if s.moves_vs() { s.split_position.to_vec() } else { Vec::new() },
        error: s.error,
        corners: None,
    }
}

/// Converts a progressive mesh to the contract; with attributes, `file` is its `.pm` in the
/// compact form, or the lossless one if asked.
pub fn progressive_to_proto(pm: &ProgressiveMesh, lossless: bool) -> proto::ProgressiveMesh {
    use meshlod_engine::pm_format::{encode, encode_lossless};
    proto::ProgressiveMesh {
        base: Some(pm_base_to_proto(pm)),
        splits: pm.splits().iter().map(split_to_proto).collect(),
        file: match (pm.has_attributes(), lossless) {
            (false, _) => Vec::new(),
            (true, false) => encode(pm),
            (true, true) => encode_lossless(pm),
        },
    }
}

/// A progressive mesh's base as the contract has it: positions and faces only, so that the
/// splits' vertex numbers stay its own (attributes would split seam vertices).
pub fn pm_base_to_proto(pm: &ProgressiveMesh) -> proto::Mesh {
    let base = pm.base();
    proto::Mesh {
        positions: base.positions.iter().flatten().copied().collect(),
        indices: base.triangles.iter().flatten().copied().collect(),
        ..Default::default()
    }
}

/// Rebuilds a progressive mesh from its contract form (a client reassembling a stream), checking
/// it by replaying every split.
pub fn progressive_from_proto(base: &proto::Mesh, splits: &[proto::VertexSplit]) -> Result<ProgressiveMesh, JobError> {
    let base = mesh_from_proto(base, "base", &MeshLimits::default())?;
    let mut out = Vec::with_capacity(splits.len());
    for (j, s) in splits.iter().enumerate() {
        let triple = |v: &[f32], what: &str| -> Result<[f32; 3], JobError> {
            <[f32; 3]>::try_from(v).map_err(|_| invalid(format!("splits[{j}].{what}"), "needs 3 floats"))
        };
        out.push(StreamedSplit {
            vs: s.vs,
            vl: s.vl.unwrap_or(NO_VERTEX),
            vr: s.vr.unwrap_or(NO_VERTEX),
            hole: match proto::Hole::try_from(s.hole) {
                Ok(proto::Hole::Unspecified) => Hole::None,
                Ok(proto::Hole::Left) => Hole::Left,
                Ok(proto::Hole::Right) => Hole::Right,
                Err(_) => return Err(invalid(format!("splits[{j}].hole"), format!("unknown value {}", s.hole))),
            },
            new_position: triple(&s.position, "position")?,
            split_position: if s.vs_position.is_empty() { None } else { Some(triple(&s.vs_position, "vs_position")?) },
            error: s.error,
        });
    }
    ProgressiveMesh::from_stream(base, out).map_err(|e| invalid("splits", e.to_string()))
}

/// Engine options from the contract's: enums mapped, unset fields given the engine's defaults.
/// Nothing is range-checked here: [`SimplifyOptions::validate`] does that, once, for every front
/// end, and its errors name the same fields. `w` is the request's (0 where unset, and where
/// `w_auto` or `w_search` will replace it).
impl TryFrom<&proto::SimplifyOptions> for SimplifyOptions {
    type Error = JobError;

    fn try_from(o: &proto::SimplifyOptions) -> Result<SimplifyOptions, JobError> {
        let w = if o.w_auto || o.w_search { 0.0 } else { o.w.unwrap_or(0.0) };
        let metric = match proto::Metric::try_from(o.metric) {
            Ok(proto::Metric::Unspecified | proto::Metric::Qfvp) => Metric::Qfvp { w },
            Ok(proto::Metric::Qem) => Metric::Qem,
            Ok(proto::Metric::Melax) => Metric::Melax,
            Err(_) => return Err(invalid("options.metric", format!("unknown value {}", o.metric))),
        };
        let placement = match proto::Placement::try_from(o.placement) {
            Ok(proto::Placement::Unspecified) => Placement::Auto,
            Ok(proto::Placement::Optimal) => Placement::Optimal,
            Ok(proto::Placement::Paper) => Placement::Paper,
            Ok(proto::Placement::Endpoint) => Placement::Endpoint,
            Err(_) => return Err(invalid("options.placement", format!("unknown value {}", o.placement))),
        };
        let normals = match proto::NormalUpdate::try_from(o.normals) {
            Ok(proto::NormalUpdate::Unspecified | proto::NormalUpdate::Linear) => NormalUpdate::Linear,
            Ok(proto::NormalUpdate::Recompute) => NormalUpdate::Recompute,
            Err(_) => return Err(invalid("options.normals", format!("unknown value {}", o.normals))),
        };
        let boundary = match proto::BoundaryMode::try_from(o.boundary) {
            Ok(proto::BoundaryMode::Unspecified | proto::BoundaryMode::Preserve) => BoundaryMode::Preserve,
            Ok(proto::BoundaryMode::Lock) => BoundaryMode::Lock,
            Err(_) => return Err(invalid("options.boundary", format!("unknown value {}", o.boundary))),
        };
        let defaults = SimplifyOptions::default();
        let options = SimplifyOptions {
            max_error: o.max_error,
            metric,
            placement,
            normals,
            boundary,
            max_normal_change_degrees: o.max_normal_change_degrees.unwrap_or(defaults.max_normal_change_degrees),
            record_progressive: o.return_progressive,
            guard: o.guard.unwrap_or(defaults.guard),
            distance_term: o.distance_term.unwrap_or(defaults.distance_term),
            lock_seams: o.lock_seams,
            attribute_weights: o.attribute_weights.as_ref().map(|w| meshlod_engine::simplify::AttributeWeights {
                uv: w.uv,
                normal: w.normal,
                color: w.color,
            }),
            prune: o.prune,
            halves: !o.whole,
            ..defaults
        };
        Ok(options.with_targets(o.target_faces.map(|n| n as usize), o.target_ratio))
    }
}

/// The jobs' request from the contract's options: the engine's options, and how w is chosen
/// (`w_auto` and `w_search` exclude each other).
impl TryFrom<&proto::SimplifyOptions> for SimplifyRequest {
    type Error = JobError;

    fn try_from(o: &proto::SimplifyOptions) -> Result<SimplifyRequest, JobError> {
        if o.w_auto && o.w_search {
            return Err(JobError::invalid("options.w_search", "not together with options.w_auto"));
        }
        let w = match (o.w_auto, o.w_search) {
            (true, _) => WChoice::Auto,
            (_, true) => WChoice::Search,
            _ => WChoice::Given(o.w.unwrap_or(0.0)),
        };
        Ok(SimplifyRequest {
            options: SimplifyOptions::try_from(o)?,
            w,
            compute_hausdorff: o.compute_hausdorff,
            progressive_lossless: o.progressive_lossless,
            compare: o.compare,
        })
    }
}

/// The jobs' refine request from the contract's: `etc` and `etc_auto` exclude each other, and so do
/// `etc` and `target_faces` (the target is for `etc_auto` or the search).
impl TryFrom<&proto::RefineRequest> for RefineRequest {
    type Error = JobError;

    fn try_from(r: &proto::RefineRequest) -> Result<RefineRequest, JobError> {
        let etc = match (r.etc, r.etc_auto) {
            (Some(_), true) => return Err(JobError::invalid("etc", "give etc or etc_auto, not both")),
            (Some(_), false) if r.target_faces.is_some() => {
                return Err(JobError::invalid(
                    "etc",
                    "give etc or target_faces, not both (or etc_auto with target_faces)",
                ));
            }
            (Some(e), false) => EtcChoice::Given(e),
            (None, true) => EtcChoice::Auto,
            (None, false) => EtcChoice::Search,
        };
        let mode = match proto::RefineMode::try_from(r.mode) {
            Ok(proto::RefineMode::Unspecified) => None,
            Ok(proto::RefineMode::Simplify) => Some(RefineMode::Simplify),
            Ok(proto::RefineMode::Subdivide) => Some(RefineMode::Subdivide),
            Ok(proto::RefineMode::Both) => Some(RefineMode::Both),
            Err(_) => return Err(invalid("mode", format!("unknown value {}", r.mode))),
        };
        Ok(RefineRequest { etc, target_faces: r.target_faces.map(|n| n as usize), mode, rounds: r.rounds.unwrap_or(1) })
    }
}

/// The contract's refine request for a jobs' one (without its input and output format).
impl From<&RefineRequest> for proto::RefineRequest {
    fn from(r: &RefineRequest) -> proto::RefineRequest {
        proto::RefineRequest {
            etc: match r.etc {
                EtcChoice::Given(e) => Some(e),
                EtcChoice::Auto | EtcChoice::Search => None,
            },
            etc_auto: r.etc == EtcChoice::Auto,
            target_faces: r.target_faces.map(|n| u32::try_from(n).unwrap_or(u32::MAX)),
            mode: match r.mode {
                None => proto::RefineMode::Unspecified,
                Some(RefineMode::Simplify) => proto::RefineMode::Simplify,
                Some(RefineMode::Subdivide) => proto::RefineMode::Subdivide,
                Some(RefineMode::Both) => proto::RefineMode::Both,
            } as i32,
            rounds: Some(r.rounds),
            ..Default::default()
        }
    }
}

/// The contract's options for a request (what a client sends): every option set, so the server
/// runs what the request says whatever its own defaults.
impl From<&SimplifyRequest> for proto::SimplifyOptions {
    fn from(r: &SimplifyRequest) -> proto::SimplifyOptions {
        let o = &r.options;
        let weights = o.attribute_weights;
        proto::SimplifyOptions {
            target_faces: o.target_faces.map(|n| u32::try_from(n).unwrap_or(u32::MAX)),
            target_ratio: o.target_ratio,
            max_error: o.max_error,
            metric: match o.metric {
                Metric::Qfvp { .. } => proto::Metric::Qfvp,
                Metric::Qem => proto::Metric::Qem,
                Metric::Melax => proto::Metric::Melax,
            } as i32,
            w: match r.w {
                WChoice::Given(w) => Some(w),
                WChoice::Auto | WChoice::Search => None,
            },
            w_auto: r.w == WChoice::Auto,
            w_search: r.w == WChoice::Search,
            placement: match o.placement {
                Placement::Auto => proto::Placement::Unspecified,
                Placement::Optimal => proto::Placement::Optimal,
                Placement::Paper => proto::Placement::Paper,
                Placement::Endpoint => proto::Placement::Endpoint,
            } as i32,
            normals: match o.normals {
                NormalUpdate::Linear => proto::NormalUpdate::Linear,
                NormalUpdate::Recompute => proto::NormalUpdate::Recompute,
            } as i32,
            boundary: match o.boundary {
                BoundaryMode::Preserve => proto::BoundaryMode::Preserve,
                BoundaryMode::Lock => proto::BoundaryMode::Lock,
            } as i32,
            lock_seams: o.lock_seams,
            max_normal_change_degrees: Some(o.max_normal_change_degrees),
            return_progressive: o.record_progressive,
            compute_hausdorff: r.compute_hausdorff,
            compare: r.compare,
            guard: Some(o.guard),
            distance_term: Some(o.distance_term),
            progressive_lossless: r.progressive_lossless,
            attribute_weights: weights.map(|w| proto::AttributeWeights { uv: w.uv, normal: w.normal, color: w.color }),
            prune: o.prune,
            whole: !o.halves,
        }
    }
}

/// The engine's refusals by rule, as the contract counts them.
pub fn refusals_to_proto(r: &meshlod_engine::simplify::Refusals) -> proto::Refusals {
    proto::Refusals {
        link: r.link as u64,
        too_few_faces: r.too_few_faces as u64,
        normal_change: r.normal_change as u64,
        needle: r.needle as u64,
        fold: r.fold as u64,
        seam: r.seam as u64,
        uv_flip: r.uv_flip as u64,
    }
}

/// A comparison's figures as the contract reports them.
pub fn compare_to_proto(r: &meshlod_engine::compare::CompareReport) -> proto::CompareReport {
    proto::CompareReport {
        mae: r.mae,
        psnr: r.psnr,
        silhouette: r.silhouette,
        views: r.views as u32,
        size: r.size as u32,
        notes: r.notes.clone(),
    }
}

/// The proto report of a Hausdorff measurement.
pub fn hausdorff_to_proto(d: &meshlod_engine::hausdorff::HausdorffReport) -> proto::HausdorffReport {
    proto::HausdorffReport {
        hausdorff: d.hausdorff,
        mean: d.mean,
        rms: d.rms,
        hausdorff_diag_pct: d.hausdorff_diag_pct,
        samples: d.samples as u64,
        hausdorff_lower: d.hausdorff_lower,
        tolerance: d.tolerance,
        converged: d.converged,
    }
}

/// Hausdorff options from a request, checked; errors name the request field.
pub fn hausdorff_options(
    tolerance: Option<f64>,
    samples: Option<u32>,
) -> Result<meshlod_engine::hausdorff::HausdorffOptions, JobError> {
    let options = meshlod_engine::hausdorff::HausdorffOptions {
        tolerance: tolerance.unwrap_or(meshlod_engine::hausdorff::HausdorffOptions::DEFAULT_TOLERANCE),
        samples: samples.map(|n| n as usize),
        ..Default::default()
    };
    options.validate().map_err(|e| match e {
        MeshError::InvalidParameter { name, reason } => invalid(name, reason),
        other => invalid("request", other.to_string()),
    })?;
    Ok(options)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_request_goes_to_the_contract_and_back_unchanged() {
        let sent = proto::SimplifyOptions {
            target_ratio: Some(0.8),
            metric: proto::Metric::Qem as i32,
            w: Some(1.5),
            placement: proto::Placement::Paper as i32,
            normals: proto::NormalUpdate::Recompute as i32,
            boundary: proto::BoundaryMode::Lock as i32,
            guard: Some(2.0),
            attribute_weights: Some(proto::AttributeWeights { uv: 0.3, normal: 0.0, color: 0.1 }),
            compute_hausdorff: true,
            compare: true,
            prune: true,
            whole: true,
            ..Default::default()
        };
        let request = SimplifyRequest::try_from(&sent).unwrap();
        assert_eq!(request.w, WChoice::Given(1.5), "the w given is kept, for the warning it draws with QEM");
        let back = SimplifyRequest::try_from(&proto::SimplifyOptions::from(&request)).unwrap();
        assert_eq!(format!("{back:?}"), format!("{request:?}"));
        for (auto, search) in [(true, false), (false, true)] {
            let o = proto::SimplifyOptions { w_auto: auto, w_search: search, ..Default::default() };
            let r = SimplifyRequest::try_from(&o).unwrap();
            assert_eq!(proto::SimplifyOptions::from(&r).w_auto, auto);
            assert_eq!(proto::SimplifyOptions::from(&r).w_search, search);
        }
        let both = proto::SimplifyOptions { w_auto: true, w_search: true, ..Default::default() };
        assert_eq!(SimplifyRequest::try_from(&both).unwrap_err().field, "options.w_search");
    }

    #[test]
    fn a_refine_request_goes_to_the_contract_and_back_unchanged() {
        for sent in [
            proto::RefineRequest { etc: Some(1.5), rounds: Some(2), ..Default::default() },
            proto::RefineRequest { etc_auto: true, target_faces: Some(900), ..Default::default() },
            proto::RefineRequest { target_faces: Some(90), mode: proto::RefineMode::Both as i32, ..Default::default() },
        ] {
            let request = RefineRequest::try_from(&sent).unwrap();
            assert_eq!(RefineRequest::try_from(&proto::RefineRequest::from(&request)).unwrap(), request);
        }
        let both = proto::RefineRequest { etc: Some(1.0), etc_auto: true, ..Default::default() };
        assert_eq!(RefineRequest::try_from(&both).unwrap_err().field, "etc");
        let bad_mode = proto::RefineRequest { etc: Some(1.0), mode: 9, ..Default::default() };
        assert_eq!(RefineRequest::try_from(&bad_mode).unwrap_err().field, "mode");
    }

    #[test]
    fn a_job_error_and_its_status_say_the_same() {
        let error = JobError::invalid("options.target_ratio", "1.5 is outside [0, 1)");
        let status = Status::from(error.clone());
        assert_eq!(status.code(), tonic::Code::InvalidArgument);
        assert_eq!(status.message(), "options.target_ratio: 1.5 is outside [0, 1)");
        assert_eq!(error_from_status(&status), error);
        assert_eq!(error.flag(), Some("--ratio"));
        // A message that names no field keeps its words and its code.
        let plain = error_from_status(&Status::failed_precondition("this server runs without a predictor model"));
        assert_eq!((plain.field.as_str(), plain.kind), ("", ErrorKind::FailedPrecondition));
        assert!(plain.reason.starts_with("this server runs without a predictor model"), "{plain}");
        let cancelled = Status::from(JobError::cancelled());
        assert_eq!(cancelled.code(), tonic::Code::Cancelled);
    }

    #[test]
    fn a_face_limit_is_the_limit_a_user_meets() {
        // Two faces and five vertices (one unused) under --max-faces 2: accepted; the message a
        // user can act on is about faces.
        let limits = MeshLimits::for_faces(2);
        let mesh = proto::Mesh { positions: vec![0.0; 15], indices: vec![0, 1, 2, 0, 2, 3], ..Default::default() };
        assert!(mesh_from_proto(&mesh, "input.mesh", &limits).is_ok());
        let three = proto::Mesh { indices: vec![0, 1, 2, 0, 2, 3, 1, 2, 3], ..mesh };
        let error = mesh_from_proto(&three, "input.mesh", &limits).unwrap_err();
        assert!(error.reason.contains("3 faces exceeds the limit of 2"), "{error}");
        assert_eq!((error.field.as_str(), error.kind), ("input.mesh", ErrorKind::InvalidArgument));
    }

    #[test]
    fn a_seam_comes_back_a_seam_not_a_cut() {
        // A closed box whose faces each have their own texture coordinates (a seam along every
        // edge): the contract sends a vertex once per value; back in the engine they are one
        // vertex again, so the surface stays closed (no border) and the values stay per corner.
        let mut mesh = meshlod_engine::procedural::sharp_box(2);
        let uvs = (0..mesh.face_count()).flat_map(|f| [[f as f32, 0.0], [f as f32, 1.0], [f as f32, 2.0]]).collect();
        mesh.corners.set_uvs(Some(uvs));
        let sent = mesh_to_proto(&mesh);
        assert_eq!(sent.positions.len() / 3, 3 * mesh.face_count(), "split once per corner");
        let back = mesh_from_proto(&sent, "input.mesh", &MeshLimits::default()).unwrap();
        assert_eq!(back.vertex_count(), mesh.vertex_count());
        assert_eq!(meshlod_engine::validate::validate(&back).boundary_edges, 0);
        assert_eq!(back.corners.uvs(), mesh.corners.uvs());
        for (t, u) in back.triangles.iter().zip(&mesh.triangles) {
            assert_eq!(t.map(|v| back.positions[v as usize]), u.map(|v| mesh.positions[v as usize]));
        }
    }

    #[test]
    fn splits_that_open_holes_travel_and_a_bad_hole_value_is_named() {
        // A sphere with faces taken out (a triangular hole each), simplified until holes close:
        // the contract carries which side is the hole's, and the rebuilt mesh matches at every
        // level.
        use meshlod_engine::procedural::{icosphere, with_triangular_holes};
        use meshlod_engine::simplify::{SimplifyOptions, simplify};
        let mesh = with_triangular_holes(&icosphere(3), 1);
        let options = SimplifyOptions { target_ratio: Some(0.95), record_progressive: true, ..Default::default() };
        let pm = simplify(&mesh, &options).unwrap().progressive.unwrap();
        assert!(pm.splits().iter().any(|s| s.hole != Hole::None));
        let sent = progressive_to_proto(&pm, false);
        assert!(sent.splits.iter().any(|s| s.hole == proto::Hole::Left as i32));
        assert!(sent.splits.iter().any(|s| s.hole == proto::Hole::Right as i32));
        let base = sent.base.as_ref().unwrap();
        let back = progressive_from_proto(base, &sent.splits).unwrap();
        for level in [0, pm.levels() / 3, pm.levels()] {
            assert_eq!(back.at_level(level), pm.at_level(level), "level {level}");
        }
        let mut bad = sent.splits.clone();
        let j = bad.iter().position(|s| s.hole != 0).unwrap();
        bad[j].hole = 7;
        let error = progressive_from_proto(base, &bad).unwrap_err();
        assert_eq!(error.field, format!("splits[{j}].hole"), "{error}");
    }
}
