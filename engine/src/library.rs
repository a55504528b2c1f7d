//! What a mesh's faces are drawn with and what travels beside them: materials, textures and images
//! in glTF's terms, a skinned asset's rig, and the point and line primitives carried as they were.
//! Shared (not copied) by every mesh made from one input; [`crate::mesh::CornerAttributes`] names
//! its materials per corner.

/// What a mesh's faces are drawn with, kept in glTF's terms so that a glTF written from the mesh
/// draws as its input did: the input's `materials`, `textures` and `samplers` JSON arrays carried
/// verbatim (their indices into each other stay valid), and its images with their bytes or where
/// to find them. OBJ materials (MTL) are translated into the same terms.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MaterialLibrary {
    /// glTF `materials`, one JSON object each.
    pub materials: Vec<serde_json::Value>,
    /// glTF `textures`.
    pub textures: Vec<serde_json::Value>,
    /// glTF `samplers`.
    pub samplers: Vec<serde_json::Value>,
    /// glTF `images`.
    pub images: Vec<Image>,
    /// Extensions the materials and textures use (glTF `extensionsUsed`), and those of them the
    /// input required.
    pub extensions_used: Vec<String>,
    /// See `extensions_used`.
    pub extensions_required: Vec<String>,
    /// What the input had that a mesh does not carry (morph targets, normals that only some
    /// primitives have, point and line primitives beside a skin, a skeleton that cannot be kept), named for the
    /// warnings of every operation that writes a result.
    pub not_carried: Vec<String>,
    /// The skeleton and animations of a skinned asset, when the mesh carries its joints and
    /// weights.
    pub rig: Option<Rig>,
    /// The input's point and line primitives, written back beside the triangles as they were.
    pub other_primitives: Vec<OtherPrimitive>,
    /// What the reader mended so that the result is valid glTF (weights that did not sum to 1),
    /// said by every operation that writes a result.
    pub mended: Vec<String>,
}

/// A glTF point or line primitive (POINTS, LINES, LINE_LOOP, LINE_STRIP: not surface, so not
/// simplified or refined), carried as it was: its positions placed in the world as the mesh's are
/// (normals and tangents turned with them) and stored as floats, as are its texture coordinates and
/// colours; its other attributes and its indices with their data as it was.
#[derive(Debug, Clone, PartialEq)]
pub struct OtherPrimitive {
    /// glTF `mode`: 0 points, 1 lines, 2 line loop, 3 line strip.
    pub mode: u32,
    /// Its material: an index into the library's `materials`.
    pub material: Option<u32>,
    /// Its attributes by glTF name (`POSITION`, `COLOR_0`, ...), each an accessor with its data.
    pub attributes: Vec<(String, RigAccessor)>,
    /// Its indices, when it has them.
    pub indices: Option<RigAccessor>,
}

impl OtherPrimitive {
    /// Whether `other` can be written as it is: a mode that is not surface, a material the
    /// library has, each accessor's bytes its count of elements, every index below the count of
    /// positions.
    pub(crate) fn check(&self, materials: usize) -> Result<(), String> {
        let other = self;
        if other.mode > 3 {
            return Err(format!("mode {} is not a point or line mode", other.mode));
        }
        if let Some(m) = other.material.filter(|&m| m as usize >= materials) {
            return Err(format!("names material {m}; there are {materials}"));
        }
        let size = |a: &RigAccessor| -> Option<(usize, usize)> {
            let components = match a.json.get("type")?.as_str()? {
                "SCALAR" => 1,
                "VEC2" => 2,
                "VEC3" => 3,
                "VEC4" => 4,
                _ => return None,
            };
            let width = match a.json.get("componentType")?.as_u64()? {
                5120 | 5121 => 1,
                5122 | 5123 => 2,
                5125 | 5126 => 4,
                _ => return None,
            };
            Some((usize::try_from(a.json.get("count")?.as_u64()?).ok()?, components * width))
        };
        let mut positions = None;
        for (name, a) in &other.attributes {
            let (count, element) = size(a).ok_or_else(|| format!("{name}: an accessor glTF does not define"))?;
            if count.checked_mul(element) != Some(a.bytes.len()) {
                return Err(format!("{name}: {} bytes for {count} elements of {element}", a.bytes.len()));
            }
            if name == "POSITION" {
                positions = Some(count);
            }
        }
        let positions = positions.ok_or("no POSITION")?;
        if let Some(indices) = &other.indices {
            let (count, width) =
                size(indices).filter(|&(_, w)| matches!(w, 1 | 2 | 4)).ok_or("indices of no integer type")?;
            if count.checked_mul(width) != Some(indices.bytes.len()) {
                return Err(format!("{} bytes of indices for {count}", indices.bytes.len()));
            }
            if let Some(bad) = indices.bytes.chunks_exact(width).map(unsigned_le).find(|&i| i >= positions) {
                return Err(format!("index {bad} is out of range ({positions} positions)"));
            }
        }
        Ok(())
    }
}

/// A skinned glTF asset's node hierarchy, skin and animations, carried so that a glTF written
/// from the mesh still moves as its input did. The mesh's positions are in the skin's bind space
/// (a skinned node's own transform is ignored, as glTF specifies), its corners carry the joints
/// and weights, and the result is drawn by the node `mesh_node`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Rig {
    /// glTF `nodes`, without their `mesh` and `camera` (a node keeps its children, transform,
    /// skin, name and extras, so the indices the skins and animations use stay valid).
    pub nodes: Vec<serde_json::Value>,
    /// The node that draws the mesh, with the skin.
    pub mesh_node: usize,
    /// glTF `scenes`, and the default one.
    pub scenes: Vec<serde_json::Value>,
    /// See `scenes`.
    pub scene: Option<usize>,
    /// glTF `skins`; `inverseBindMatrices` refer to `accessors`.
    pub skins: Vec<serde_json::Value>,
    /// glTF `animations`; their samplers' `input` and `output` refer to `accessors`.
    pub animations: Vec<serde_json::Value>,
    /// The accessors the skins and animations read, with their data.
    pub accessors: Vec<RigAccessor>,
}

impl Rig {
    /// Number of joints of the skin that draws the mesh (what a corner's joint indices are below).
    pub fn joint_count(&self) -> usize {
        let skin = self.nodes.get(self.mesh_node).and_then(|n| n.get("skin")).and_then(|s| s.as_u64());
        skin.and_then(|s| self.skins.get(s as usize))
            .and_then(|s| s.get("joints"))
            .and_then(|j| j.as_array())
            .map_or(0, Vec::len)
    }
}

/// One accessor of a [`Rig`] or an [`OtherPrimitive`]: its JSON (`componentType`, `type`, `count`, `normalized`, `min`,
/// `max`, `name`; no `bufferView`, `byteOffset` or `sparse`) and its elements packed one after
/// another.
#[derive(Debug, Clone, PartialEq)]
pub struct RigAccessor {
    /// See [`RigAccessor`].
    pub json: serde_json::Value,
    /// See [`RigAccessor`].
    pub bytes: Vec<u8>,
}

/// One image of a [`MaterialLibrary`].
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// The image's JSON without `uri`, `bufferView` and `mimeType` (its name, extras, ...).
    pub json: serde_json::Value,
    /// Where its bytes are.
    pub source: ImageSource,
    /// Its media type, when known (`image/png`, `image/jpeg`, ...).
    pub mime_type: Option<String>,
}

/// Where an image's bytes are.
#[derive(Debug, Clone, PartialEq)]
pub enum ImageSource {
    /// Held here (from a GLB's binary chunk or a data URI).
    Bytes(Vec<u8>),
    /// A file on disk (a relative URI resolved against the input's folder).
    File(std::path::PathBuf),
    /// A URI that could not be resolved (bytes that came without their folder): carried as is.
    Uri(String),
}

impl MaterialLibrary {
    /// The name of material `index` (its `name`, else `material{index}`).
    pub fn material_name(&self, index: u32) -> String {
        self.materials
            .get(index as usize)
            .and_then(|m| m.get("name"))
            .and_then(|n| n.as_str())
            .map_or_else(|| format!("material{index}"), str::to_string)
    }
}

/// An unsigned integer stored little-endian in `bytes` (at most 8 of them), as glTF stores indices.
pub(crate) fn unsigned_le(bytes: &[u8]) -> usize {
    bytes.iter().rev().fold(0usize, |x, &byte| (x << 8) | usize::from(byte))
}
