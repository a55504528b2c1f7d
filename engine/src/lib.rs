//! meshlod's geometry engine: mesh core, file I/O, validation, the Hausdorff instrument and the
//! level-of-detail algorithms. Pure and synchronous: no async, no networking.
//!
//! Distances are reported in *paper units* (the reference mesh centred and scaled so the largest
//! side of its bounding box spans [−1, 1]) and in *percent of the bounding-box diagonal*; see
//! [`mesh::DistanceUnits`].

pub mod appearance;
pub mod attributes;
pub mod bvh;
pub mod compare;
pub mod datasets;
pub mod error;
mod fan;
pub mod features;
pub mod hausdorff;
mod ids;
pub mod io;
pub mod library;
pub mod mesh;
mod parallel;
pub mod pm;
pub mod pm_format;
mod prefetch;
pub mod procedural;
pub mod quadric;
mod queue;
pub mod refine;
pub mod rng;
pub mod simplify;
pub mod topology;
pub mod validate;

pub use error::MeshError;
pub use mesh::{Bounds, DistanceUnits, FaceId, Mesh, VertexId};
