//! Glue between the engine's features and the predictor's model: one place that builds the
//! model inputs, so the CLI and the server ask the same question.

use std::path::Path;

use meshlod_engine::Mesh;
use meshlod_engine::features::{ETC_INPUT_NAMES, Shape, W_INPUT_NAMES, etc_input, shape_features, w_input};
use meshlod_predictor::{Predictor, PredictorError, WPrediction};

/// What the predictor advises for one mesh and target.
#[derive(Debug, Clone)]
pub struct Advice {
    /// w with class probabilities.
    pub w: WPrediction,
    /// ETC estimate for reaching the target with the refiner (subdividing when the target has more
    /// faces than the mesh, simplifying otherwise).
    pub etc: f64,
    /// Version of the model.
    pub model_version: String,
}

/// Loads the model from `dir` (`predictor.onnx` and `metadata.json`), or the embedded one, and
/// checks that its features are the engine's, in the same order.
pub fn load(dir: Option<&Path>) -> Result<Predictor, PredictorError> {
    let predictor = match dir {
        Some(d) => Predictor::from_files(&d.join("predictor.onnx"), &d.join("metadata.json"))?,
        None => Predictor::embedded()?,
    };
    predictor.check_feature_names(&W_INPUT_NAMES, &ETC_INPUT_NAMES)?;
    Ok(predictor)
}

/// Advice from precomputed shape features.
pub fn advise_features(
    predictor: &Predictor,
    shape: &Shape,
    faces_in: usize,
    target_faces: usize,
) -> Result<Advice, PredictorError> {
    let subdivide = target_faces > faces_in;
    let (w, etc) = predictor.predict(
        &w_input(shape, faces_in, target_faces.min(faces_in)),
        &etc_input(shape, subdivide, faces_in, target_faces),
    )?;
    Ok(Advice { w, etc: etc as f64, model_version: predictor.metadata().model_version.clone() })
}

/// Advice for a mesh (its shape features are computed here).
pub fn advise(predictor: &Predictor, mesh: &Mesh, target_faces: usize) -> Result<Advice, PredictorError> {
    advise_features(predictor, &shape_features(mesh), mesh.face_count(), target_faces)
}
