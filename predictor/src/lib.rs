//! meshlod's parameter predictor: an ONNX model, trained in `training/`, that turns features into
//! the QFVP exponent w (a class of {0, 0.5, 1, 1.5, 2} with probabilities) and the refine ETC.
//!
//! The model is loaded once with tract-onnx and shared (`Arc<Predictor>` is `Send + Sync`). Its
//! input shapes are pinned to one row each, which lets tract optimise the plan for single calls.
//! This crate computes nothing geometric: the features come from `meshlod_engine::features`, and
//! the metadata shipped with the model names them in order so callers can check they agree.

use std::path::Path;
use std::sync::Arc;

use serde::Deserialize;
use tract_onnx::prelude::*;

/// The shipped model, its metadata and its golden input/output.
pub const EMBEDDED_MODEL: &[u8] = include_bytes!("../model/predictor.onnx");
/// Metadata of the shipped model (JSON).
pub const EMBEDDED_METADATA: &str = include_str!("../model/metadata.json");
/// Golden inputs and outputs of the shipped model (JSON), written by the training script.
pub const EMBEDDED_GOLDEN: &str = include_str!("../model/golden.json");

/// Why a model could not be loaded or run.
#[derive(Debug, thiserror::Error)]
pub enum PredictorError {
    /// The metadata is not valid JSON of the expected shape.
    #[error("model metadata: {0}")]
    Metadata(String),
    /// tract could not load, optimise or run the model.
    #[error("model: {0}")]
    Model(String),
    /// An input has the wrong number of features.
    #[error("{input}: expected {expected} features, got {got}")]
    InputLength {
        /// Which input.
        input: &'static str,
        /// Features the model takes.
        expected: usize,
        /// Features given.
        got: usize,
    },
    /// A feature is NaN or infinite.
    #[error("{input}[{index}] is not finite")]
    NonFinite {
        /// Which input.
        input: &'static str,
        /// Position of the value.
        index: usize,
    },
    /// The model's feature names differ from the caller's.
    #[error("the model's {input} features {model:?} differ from the engine's {engine:?}")]
    FeatureMismatch {
        /// Which input.
        input: &'static str,
        /// Names in the model metadata.
        model: Vec<String>,
        /// Names the caller computes.
        engine: Vec<String>,
    },
    /// A file could not be read.
    #[error("{path}: {message}")]
    Io {
        /// File.
        path: String,
        /// The system's message.
        message: String,
    },
}

/// What the training script wrote about the model (the fields the runtime needs).
#[derive(Debug, Clone, Deserialize)]
pub struct Metadata {
    /// Version string, reported with every prediction.
    pub model_version: String,
    /// Names of the w classifier's inputs, in order.
    pub w_input_names: Vec<String>,
    /// Names of the ETC regressor's inputs, in order.
    pub etc_input_names: Vec<String>,
    /// The w value of each output class.
    pub classes: Vec<f64>,
}

/// A prediction of w.
#[derive(Debug, Clone, PartialEq)]
pub struct WPrediction {
    /// The most probable class.
    pub w: f64,
    /// Probability of each class, in the order of `classes`.
    pub probabilities: Vec<f32>,
    /// The classes.
    pub classes: Vec<f64>,
}

/// A loaded model.
#[derive(Debug, Clone)]
pub struct Predictor {
    plan: Arc<TypedRunnableModel>,
    metadata: Metadata,
}

fn model_error(e: impl std::fmt::Display) -> PredictorError {
    PredictorError::Model(e.to_string())
}

impl Predictor {
    /// The model shipped inside the binary.
    pub fn embedded() -> Result<Predictor, PredictorError> {
        Predictor::from_bytes(EMBEDDED_MODEL, EMBEDDED_METADATA)
    }

    /// A model and its metadata from files (`predictor.onnx`, `metadata.json` of a training run).
    pub fn from_files(model: &Path, metadata: &Path) -> Result<Predictor, PredictorError> {
        let read = |p: &Path| {
            std::fs::read(p).map_err(|e| PredictorError::Io { path: p.display().to_string(), message: e.to_string() })
        };
        let metadata_text = String::from_utf8(read(metadata)?).map_err(|e| PredictorError::Metadata(e.to_string()))?;
        Predictor::from_bytes(&read(model)?, &metadata_text)
    }

    /// A model from bytes and its metadata from JSON text.
    pub fn from_bytes(model: &[u8], metadata: &str) -> Result<Predictor, PredictorError> {
        let metadata: Metadata = serde_json::from_str(metadata).map_err(|e| PredictorError::Metadata(e.to_string()))?;
        if metadata.classes.is_empty() || metadata.w_input_names.is_empty() || metadata.etc_input_names.is_empty() {
            return Err(PredictorError::Metadata("classes and input names must not be empty".into()));
        }
        let plan = tract_onnx::onnx()
            .model_for_read(&mut std::io::Cursor::new(model))
            .and_then(|m| m.with_input_fact(0, f32::fact([1, metadata.w_input_names.len()]).into()))
            .and_then(|m| m.with_input_fact(1, f32::fact([1, metadata.etc_input_names.len()]).into()))
            .and_then(|m| m.into_optimized())
            .and_then(|m| m.into_runnable())
            .map_err(model_error)?;
        Ok(Predictor { plan, metadata })
    }

    /// The model's metadata.
    pub fn metadata(&self) -> &Metadata {
        &self.metadata
    }

    /// Checks that the model takes the features the caller computes, in the same order.
    pub fn check_feature_names(&self, w_names: &[&str], etc_names: &[&str]) -> Result<(), PredictorError> {
        for (input, model, engine) in [
            ("w_input", &self.metadata.w_input_names, w_names),
            ("etc_input", &self.metadata.etc_input_names, etc_names),
        ] {
            if model.iter().map(String::as_str).ne(engine.iter().copied()) {
                return Err(PredictorError::FeatureMismatch {
                    input,
                    model: model.clone(),
                    engine: engine.iter().map(|s| s.to_string()).collect(),
                });
            }
        }
        Ok(())
    }

    fn tensor(&self, input: &'static str, values: &[f32], expected: usize) -> Result<TValue, PredictorError> {
        if values.len() != expected {
            return Err(PredictorError::InputLength { input, expected, got: values.len() });
        }
        if let Some(index) = values.iter().position(|v| !v.is_finite()) {
            return Err(PredictorError::NonFinite { input, index });
        }
        Ok(Tensor::from_shape(&[1, expected], values).map_err(model_error)?.into())
    }

    /// Runs the model once: w from `w_input` and ETC from `etc_input`.
    pub fn predict(&self, w_input: &[f32], etc_input: &[f32]) -> Result<(WPrediction, f32), PredictorError> {
        let inputs = tvec!(
            self.tensor("w_input", w_input, self.metadata.w_input_names.len())?,
            self.tensor("etc_input", etc_input, self.metadata.etc_input_names.len())?
        );
        let outputs = self.plan.run(inputs).map_err(model_error)?;
        let probabilities: Vec<f32> =
            outputs[0].to_plain_array_view::<f32>().map_err(model_error)?.iter().copied().collect();
        let etc = *outputs[1]
            .to_plain_array_view::<f32>()
            .map_err(model_error)?
            .iter()
            .next()
            .ok_or_else(|| PredictorError::Model("empty ETC output".into()))?;
        if probabilities.len() != self.metadata.classes.len() {
            return Err(PredictorError::Model(format!(
                "{} probabilities for {} classes",
                probabilities.len(),
                self.metadata.classes.len()
            )));
        }
        let best = (0..probabilities.len()).max_by(|&a, &b| probabilities[a].total_cmp(&probabilities[b])).unwrap_or(0);
        Ok((WPrediction { w: self.metadata.classes[best], probabilities, classes: self.metadata.classes.clone() }, etc))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Deserialize)]
    struct Golden {
        w_input: Vec<Vec<f32>>,
        etc_input: Vec<Vec<f32>>,
        w_probabilities: Vec<Vec<f32>>,
        etc: Vec<f32>,
    }

    /// The shipped model, or — when `MESHLOD_MODEL_DIR` is set (the training pipeline's check) —
    /// the model in that folder, with its golden file.
    fn model_under_test() -> (Predictor, String) {
        match std::env::var_os("MESHLOD_MODEL_DIR") {
            Some(dir) => {
                let dir = std::path::PathBuf::from(dir);
                let predictor = Predictor::from_files(&dir.join("predictor.onnx"), &dir.join("metadata.json")).unwrap();
                (predictor, std::fs::read_to_string(dir.join("golden.json")).unwrap())
            }
            None => (Predictor::embedded().unwrap(), EMBEDDED_GOLDEN.to_string()),
        }
    }

    #[test]
    fn model_matches_its_golden_outputs() {
        let (predictor, golden) = model_under_test();
        let golden: Golden = serde_json::from_str(&golden).unwrap();
        assert!(!golden.w_input.is_empty());
        for i in 0..golden.w_input.len().min(golden.etc_input.len()) {
            let (w, etc) = predictor.predict(&golden.w_input[i], &golden.etc_input[i]).unwrap();
            for (a, b) in w.probabilities.iter().zip(&golden.w_probabilities[i]) {
                assert!((a - b).abs() <= 1e-4, "row {i}: probability {a} vs golden {b}");
            }
            let relative = (etc - golden.etc[i]).abs() / golden.etc[i].abs().max(1.0);
            assert!(relative <= 1e-4, "row {i}: ETC {etc} vs golden {}", golden.etc[i]);
            assert!(predictor.metadata().classes.contains(&w.w));
        }
    }

    #[test]
    fn bad_inputs_are_errors_not_panics() {
        let predictor = Predictor::embedded().unwrap();
        let n_w = predictor.metadata().w_input_names.len();
        let n_etc = predictor.metadata().etc_input_names.len();
        assert!(matches!(predictor.predict(&[0.0; 3], &vec![0.0; n_etc]), Err(PredictorError::InputLength { .. })));
        let mut nan = vec![0.0; n_w];
        nan[1] = f32::NAN;
        assert!(matches!(predictor.predict(&nan, &vec![0.0; n_etc]), Err(PredictorError::NonFinite { index: 1, .. })));
        assert!(matches!(Predictor::from_bytes(b"not onnx", EMBEDDED_METADATA), Err(PredictorError::Model(_))));
        assert!(matches!(Predictor::from_bytes(EMBEDDED_MODEL, "{}"), Err(PredictorError::Metadata(_))));
        assert!(matches!(predictor.check_feature_names(&["x"], &["y"]), Err(PredictorError::FeatureMismatch { .. })));
    }
}
