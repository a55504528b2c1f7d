//! Energy-operator level of detail: one operator decides, per triangle, whether a region is
//! simplified (triangle collapse below the threshold) or refined (adaptive modified butterfly
//! above it). Threshold = ETC × mean face energy of the input.
//!
//! Source: Wang, Li, Liu, Wang, "LOD modeling method for three-dimensional objects with energy
//! operator", Journal of System Simulation 34(2), 2022 (`../shared/papers/energy-operator-lod.txt`).
//!
//! Files: [`energy`] (the operator), `coarsen` (triangle collapse), [`subdivide`] (butterfly and
//! transitions); this module holds the options, the ETC search for a target face count, and the
//! public entry [`refine`].

mod coarsen;
pub mod energy;
pub mod subdivide;

use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use serde::Serialize;

pub use energy::EnergyOperator;
pub use subdivide::subdivide_uniform;

use crate::error::MeshError;
use crate::mesh::Mesh;
use crate::topology::Topology;

/// Which side of the threshold is acted on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum RefineMode {
    /// Collapse faces below the threshold (coarser model).
    Simplify,
    /// Subdivide faces above the threshold (finer model).
    Subdivide,
    /// Both: collapse below, then subdivide above the same threshold.
    Both,
}

/// Options of [`refine`]. Give `etc`, or `target_faces` (the ETC is then searched).
#[derive(Debug, Clone)]
pub struct RefineOptions {
    /// Energy threshold coefficient: threshold = ETC × mean face energy of the input.
    pub etc: Option<f64>,
    /// Face count to reach; the ETC that reaches it is searched and reported.
    pub target_faces: Option<usize>,
    /// What to do.
    pub mode: RefineMode,
    /// Subdivision rounds (energies are recomputed between rounds; the threshold stays).
    pub rounds: u32,
    /// Set to `true` by another thread to stop the work ([`MeshError::Cancelled`]).
    pub cancel: Option<Arc<AtomicBool>>,
    /// Most faces the output may have: a subdivision round that would pass it is refused before
    /// it is built ([`MeshError::TooLarge`]); `None` is no limit.
    pub max_faces: Option<usize>,
}

impl Default for RefineOptions {
    fn default() -> Self {
        RefineOptions {
            etc: Some(1.0),
            target_faces: None,
            mode: RefineMode::Subdivide,
            rounds: 1,
            cancel: None,
            max_faces: None,
        }
    }
}

/// Figures of one run.
#[derive(Debug, Clone, Serialize)]
pub struct RefineStats {
    /// Faces of the (prepared) input.
    pub faces_in: usize,
    /// Faces of the output.
    pub faces_out: usize,
    /// The ETC used (given, or found for the target).
    pub etc: f64,
    /// The absolute energy threshold.
    pub threshold: f64,
    /// Mode run.
    pub mode: RefineMode,
    /// Subdivision rounds run.
    pub rounds: u32,
    /// Edges split over all rounds.
    pub split_edges: usize,
    /// Edge collapses performed by triangle collapses.
    pub collapses: usize,
    /// Wall time in seconds.
    pub seconds: f64,
}

/// Result of [`refine`].
#[derive(Debug, Clone)]
pub struct Refined {
    /// The output mesh.
    pub mesh: Mesh,
    /// Figures of the run.
    pub stats: RefineStats,
}

/// Largest number of subdivision rounds accepted (each can quadruple the face count).
pub const MAX_ROUNDS: u32 = 4;

/// Most bisection steps of the ETC search when several rounds make the count non-trivial.
const MAX_SEARCH_STEPS: usize = 40;

/// Edges to split in one round: those with a face above the threshold.
fn hot_edges(topology: &Topology, energies: &EnergyOperator, threshold: f64) -> Vec<bool> {
    (0..topology.edges.len())
        .map(|e| topology.edge_faces.get(e).iter().any(|f| energies.face_energy[f.index()] > threshold))
        .collect()
}

/// Subdivides up to `rounds` times; before each round, the face count it would give is known
/// exactly (each split edge adds one face per face on it), and a round that would pass
/// `max_faces` is refused before it is built.
fn subdivide_rounds(
    mesh: &Mesh,
    threshold: f64,
    rounds: u32,
    max_faces: usize,
    cancel: Option<&AtomicBool>,
) -> Result<(Mesh, usize), MeshError> {
    let mut current = mesh.clone();
    let mut split = 0;
    for _ in 0..rounds {
        if cancel.is_some_and(|c| c.load(std::sync::atomic::Ordering::Relaxed)) {
            return Err(MeshError::Cancelled);
        }
        let topology = Topology::new(&current);
        let energies = EnergyOperator::new(&current);
        let edges = hot_edges(&topology, &energies, threshold);
        let count = edges.iter().filter(|&&e| e).count();
        if count == 0 {
            break;
        }
        let added: usize = (0..edges.len()).filter(|&e| edges[e]).map(|e| topology.edge_faces.get(e).len()).sum();
        let faces = current.face_count() + added;
        if faces > max_faces {
            return Err(MeshError::TooLarge {
                file: None,
                what: "faces (refine output)",
                count: faces as u64,
                limit: max_faces as u64,
            });
        }
        split += count;
        current = subdivide::subdivide_edges(&current, &topology, &edges);
    }
    Ok((current, split))
}

/// ETC for one subdivision round that gives the face count closest to `target`, exactly: an
/// edge splits iff its hottest face is above the threshold, and each split edge adds one face
/// per face on it.
fn etc_for_subdivision_target(mesh: &Mesh, energies: &EnergyOperator, target: usize) -> f64 {
    let topology = Topology::new(mesh);
    let mut keys: Vec<(f64, usize)> = (0..topology.edges.len())
        .map(|e| {
            let faces = topology.edge_faces.get(e);
            (faces.iter().map(|f| energies.face_energy[f.index()]).fold(f64::NEG_INFINITY, f64::max), faces.len())
        })
        .collect();
    keys.sort_by(|a, b| b.0.total_cmp(&a.0));
    // Thresholds between consecutive distinct keys; pick the count closest to the target.
    let mut best = (mesh.face_count().abs_diff(target), keys.first().map_or(0.0, |k| k.0));
    let mut count = mesh.face_count();
    let mut i = 0;
    while i < keys.len() {
        let key = keys[i].0;
        while i < keys.len() && keys[i].0 == key {
            count += keys[i].1;
            i += 1;
        }
        let below = keys.get(i).map_or(0.0, |k| k.0);
        let threshold = 0.5 * (key + below); // splits every edge with key ≥ `key`
        if count.abs_diff(target) < best.0 {
            best = (count.abs_diff(target), threshold);
        }
        if count > target {
            break;
        }
    }
    if energies.mean_face_energy > 0.0 { best.1 / energies.mean_face_energy } else { 0.0 }
}

/// ETC whose coarsening run stops as close as possible to where the target run stopped: above
/// every energy popped before, and, when possible, at most the next one.
fn etc_for_coarsening(popped: &[f64], mean: f64) -> f64 {
    let highest = popped.iter().copied().fold(0.0, f64::max);
    let threshold = if highest > 0.0 { highest * (1.0 + 1e-9) } else { f64::MIN_POSITIVE };
    if mean > 0.0 { threshold / mean } else { 0.0 }
}

/// Most faces one edge may have in a mesh given to [`refine`]: a manifold edge has two, a fin
/// three; a fan of thousands (a stack of copies of one triangle, a book of faces on one edge) would
/// make the energies and the collapses quadratic in the input.
pub const MAX_FACES_PER_EDGE: usize = 16;

/// Refuses meshes with an edge of more than [`MAX_FACES_PER_EDGE`] faces, in O(n log n).
fn check_fans(mesh: &Mesh) -> Result<(), MeshError> {
    let mut edges: Vec<(u32, u32)> = Vec::with_capacity(3 * mesh.face_count());
    for t in &mesh.triangles {
        for i in 0..3 {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            edges.push((a.min(b), a.max(b)));
        }
    }
    edges.sort_unstable();
    for run in edges.chunk_by(|x, y| x == y) {
        if run.len() > MAX_FACES_PER_EDGE {
            let (a, b) = run[0];
            return Err(MeshError::InvalidParameter {
                name: "input",
                reason: format!(
                    "edge ({a}, {b}) has {} faces; refine accepts at most {MAX_FACES_PER_EDGE} faces on one edge \
                     (clean the mesh first: duplicate or stacked faces)",
                    run.len()
                ),
            });
        }
    }
    Ok(())
}

/// Runs the energy-operator LOD on `mesh`.
pub fn refine(mesh: &Mesh, options: &RefineOptions) -> Result<Refined, MeshError> {
    let started = Instant::now();
    mesh.check()?;
    // Subdivision carries the attributes (interpolated per face); triangle collapse drops them.
    let prepared = crate::simplify::prepare_with_attributes(mesh);
    if prepared.triangles.is_empty() {
        return Err(MeshError::Empty { what: "no faces" });
    }
    check_options(options)?;
    check_fans(&prepared)?;
    let faces_in = prepared.face_count();
    // Every face of the output exists in memory: refuse targets whose ETC search could not end.
    let limit = faces_in.saturating_mul(4usize.pow(options.rounds));
    if let Some(t) = options.target_faces
        && options.mode == RefineMode::Subdivide
        && t > limit
    {
        return Err(MeshError::InvalidParameter {
            name: "target_faces",
            reason: format!("{t} faces need more than {} rounds of 1→4 subdivision from {faces_in}", options.rounds),
        });
    }
    let max_faces = options.max_faces.unwrap_or(usize::MAX);
    if let Some(t) = options.target_faces
        && t > max_faces
    {
        return Err(MeshError::TooLarge {
            file: None,
            what: "faces (refine target)",
            count: t as u64,
            limit: max_faces as u64,
        });
    }
    let energies = EnergyOperator::new(&prepared);
    let mean = energies.mean_face_energy;
    let cancel = options.cancel.as_deref();
    let (mesh_out, etc, split_edges, collapses) = match (options.mode, options.etc, options.target_faces) {
        (RefineMode::Simplify, Some(etc), _) => {
            let c = coarsen::coarsen(&prepared, etc * mean, 0, cancel)?;
            (c.mesh, etc, 0, c.collapses)
        }
        (RefineMode::Simplify, None, Some(target)) => {
            let c = coarsen::coarsen(&prepared, f64::INFINITY, target, cancel)?;
            let etc = etc_for_coarsening(&c.popped, mean);
            (c.mesh, etc, 0, c.collapses)
        }
        (RefineMode::Subdivide, Some(etc), _) => {
            let (m, split) = subdivide_rounds(&prepared, etc * mean, options.rounds, max_faces, cancel)?;
            (m, etc, split, 0)
        }
        (RefineMode::Subdivide, None, Some(target)) => {
            let etc = if options.rounds == 1 {
                etc_for_subdivision_target(&prepared, &energies, target)
            } else {
                search_etc(&prepared, mean, target, options.rounds, max_faces, cancel)?
            };
            let (m, split) = subdivide_rounds(&prepared, etc * mean, options.rounds, max_faces, cancel)?;
            (m, etc, split, 0)
        }
        (RefineMode::Both, etc, target) => {
            let etc = match (etc, target) {
                (Some(e), _) => e,
                _ => {
                    return Err(MeshError::InvalidParameter {
                        name: "mode",
                        reason: "mode both needs an explicit ETC".into(),
                    });
                }
            };
            let c = coarsen::coarsen(&prepared, etc * mean, 0, cancel)?;
            let (m, split) = subdivide_rounds(&c.mesh, etc * mean, options.rounds, max_faces, cancel)?;
            (m, etc, split, c.collapses)
        }
        (_, None, None) => unreachable!("checked above"),
    };
    let stats = RefineStats {
        faces_in,
        faces_out: mesh_out.face_count(),
        etc,
        threshold: etc * mean,
        mode: options.mode,
        rounds: options.rounds,
        split_edges,
        collapses,
        seconds: started.elapsed().as_secs_f64(),
    };
    Ok(Refined { mesh: mesh_out, stats })
}

/// The options' own checks, before any work: rounds in range, an ETC or a target, a target of at
/// least one face.
fn check_options(options: &RefineOptions) -> Result<(), MeshError> {
    if options.rounds == 0 || options.rounds > MAX_ROUNDS {
        return Err(MeshError::InvalidParameter {
            name: "rounds",
            reason: format!("{} is outside 1..={MAX_ROUNDS}", options.rounds),
        });
    }
    if let Some(etc) = options.etc
        && (etc.is_nan() || etc < 0.0)
    {
        return Err(MeshError::InvalidParameter { name: "etc", reason: format!("{etc} must be ≥ 0") });
    }
    if options.etc.is_none() && options.target_faces.is_none() {
        return Err(MeshError::InvalidParameter { name: "etc", reason: "give an ETC or a target face count".into() });
    }
    if options.target_faces == Some(0) {
        return Err(MeshError::InvalidParameter { name: "target_faces", reason: "target must be at least 1".into() });
    }
    Ok(())
}

/// Bisection on ETC (face count falls as ETC rises) for multi-round subdivision.
fn search_etc(
    mesh: &Mesh,
    mean: f64,
    target: usize,
    rounds: u32,
    max_faces: usize,
    cancel: Option<&AtomicBool>,
) -> Result<f64, MeshError> {
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    // A trial over the limit is simply too many faces: the search raises the ETC.
    let count = |etc: f64| match subdivide_rounds(mesh, etc * mean, rounds, max_faces, cancel) {
        Ok((m, _)) => Ok(m.face_count()),
        Err(MeshError::TooLarge { .. }) => Ok(usize::MAX),
        Err(e) => Err(e),
    };
    while count(hi)? > target && hi < 1e6 {
        hi *= 2.0;
    }
    let mut best = (usize::MAX, hi);
    for _ in 0..MAX_SEARCH_STEPS {
        let mid = 0.5 * (lo + hi);
        let n = count(mid)?;
        if n.abs_diff(target) < best.0 {
            best = (n.abs_diff(target), mid);
        }
        if n.abs_diff(target) * 200 <= target {
            break; // within 0.5%
        }
        if n > target { lo = mid } else { hi = mid }
    }
    Ok(best.1)
}
