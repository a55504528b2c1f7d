//! glTF 2.0, both ways: `read` (the document, through the `gltf` crate, after `checks` has looked
//! at what the crate would index unchecked), `channels` (the attributes beyond the engine's own,
//! such as `_FEATURE_ID_0`, read into channels), `passthrough` (point and line primitives carried
//! as they were), `write` (GLB or JSON), and `accessor` (integer and float data, both ways).

pub(super) mod accessor;
mod channels;
mod checks;
mod passthrough;
pub(super) mod read;
pub(super) mod write;
