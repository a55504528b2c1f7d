//! The w search: one simplification per candidate w, the one closest to the input kept.

use std::time::Instant;

use crate::error::MeshError;
use crate::hausdorff::{HausdorffOptions, HausdorffReport, hausdorff};
use crate::mesh::Mesh;

use super::options::{Metric, Simplified, SimplifyOptions};
use super::pipeline::simplify;

/// Outcome of [`simplify_search_w`].
#[derive(Debug, Clone)]
pub struct WSearch {
    /// The simplification with the lowest error; its `stats.seconds` is the wall time of the whole
    /// search.
    pub best: Simplified,
    /// Its w.
    pub w: f64,
    /// Every candidate: (w, symmetric Hausdorff distance to the input in paper units), in the
    /// order given.
    pub errors: Vec<(f64, f64)>,
    /// The measurement that chose `best` (input vs `best.mesh`, default options): callers that
    /// report it need not measure again.
    pub hausdorff: HausdorffReport,
}

/// Simplifies with QFVP once per candidate w (in parallel) and keeps the result closest to the
/// input by symmetric Hausdorff distance; ties go to the earlier candidate. The exact answer the
/// predictor only estimates, at the price of one simplification and one measurement per candidate.
/// `options.metric` must be QFVP or QEM (its w is replaced by each candidate in turn).
pub fn simplify_search_w(mesh: &Mesh, options: &SimplifyOptions, candidates: &[f64]) -> Result<WSearch, MeshError> {
    use rayon::prelude::*;
    if options.metric == Metric::Melax {
        return Err(MeshError::InvalidParameter {
            name: "metric",
            reason: "a w search needs the QFVP metric (Melax has no w)".into(),
        });
    }
    if candidates.is_empty() {
        return Err(MeshError::InvalidParameter { name: "w", reason: "no candidate w to search".into() });
    }
    let started = Instant::now();
    let runs: Vec<(f64, Simplified, HausdorffReport)> = candidates
        .par_iter()
        .map(|&w| {
            let run = simplify(mesh, &SimplifyOptions { metric: Metric::Qfvp { w }, ..options.clone() })?;
            let measured =
                hausdorff(mesh, &run.mesh, &HausdorffOptions { cancel: options.cancel.clone(), ..Default::default() })?;
            Ok((w, run, measured))
        })
        .collect::<Result<_, MeshError>>()?;
    let errors = runs.iter().map(|(w, _, d)| (*w, d.hausdorff)).collect();
    let (w, mut best, hausdorff) = runs
        .into_iter()
        .reduce(|best, next| if next.2.hausdorff < best.2.hausdorff { next } else { best })
        .expect("at least one candidate");
    best.stats.seconds = started.elapsed().as_secs_f64();
    Ok(WSearch { best, w, errors, hausdorff })
}
