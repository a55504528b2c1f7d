//! Per-corner attributes as channels: each one a semantic (what the values mean) and its values,
//! one per triangle corner. Everything that names, picks, compares, checks or encodes attributes
//! loops over the channels; only the readers and writers of a format, and the few stages that
//! treat a semantic in its own way (normals made unit again, skins blended), look at a channel's
//! semantic. Adding a kind of attribute is a reader, a writer and, where a value needs its own
//! treatment, a line where that treatment is.

use std::borrow::Cow;

use crate::error::MeshError;
use crate::library::{MaterialLibrary, Rig};

/// What a channel's values mean. The order of the variants is the order of
/// [`CornerAttributes::channels`] (and of [`CornerAttributes::names`]).
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Semantic {
    /// Unit normals (`[f32; 3]`).
    Normal,
    /// Texture coordinates of set `n` (`[f32; 2]`), with the origin [`CornerAttributes::uv_origin_top`] says.
    TexCoord(u8),
    /// A unit vector along the texture's u direction and, as the fourth component, ±1 for the
    /// handedness of the bitangent (`[f32; 4]`, glTF TANGENT).
    Tangent,
    /// Colours of set `n`, RGBA in [0, 1] (`[f32; 4]`).
    Color(u8),
    /// Four joints of set `n` (`[u16; 4]`), as indices into the rig's skin's `joints`; present
    /// exactly when the weights of the same set are.
    Joints(u8),
    /// How much each of the same set's joints moves the vertex (`[f32; 4]`).
    Weights(u8),
    /// An index into the library's materials, or [`NO_MATERIAL`] (`u32`, the same at a face's
    /// three corners). A vertex where faces of two materials meet is a seam.
    Material,
    /// A value the engine has no meaning for, carried as it is (a glTF attribute whose name
    /// starts with `_`, such as `_FEATURE_ID_0`).
    Custom(String),
}

impl Semantic {
    /// The name `info` and warnings give the channel: "normal", "uv", "uv1", "tangent", "color",
    /// "joints", "weights", "material", or a custom channel's own name.
    pub fn name(&self) -> &str {
        const UV: [&str; 8] = ["uv", "uv1", "uv2", "uv3", "uv4", "uv5", "uv6", "uv7"];
        const COLOR: [&str; 8] = ["color", "color1", "color2", "color3", "color4", "color5", "color6", "color7"];
        const JOINTS: [&str; 8] =
            ["joints", "joints1", "joints2", "joints3", "joints4", "joints5", "joints6", "joints7"];
        const WEIGHTS: [&str; 8] =
            ["weights", "weights1", "weights2", "weights3", "weights4", "weights5", "weights6", "weights7"];
        let set = |names: &'static [&'static str; 8], n: u8| names[usize::from(n).min(7)];
        match self {
            Semantic::Normal => "normal",
            Semantic::TexCoord(n) => set(&UV, *n),
            Semantic::Tangent => "tangent",
            Semantic::Color(n) => set(&COLOR, *n),
            Semantic::Joints(n) => set(&JOINTS, *n),
            Semantic::Weights(n) => set(&WEIGHTS, *n),
            Semantic::Material => "material",
            Semantic::Custom(name) => name,
        }
    }
}

/// The material value of a face that has none (glTF's default material): [`crate::ids::NONE`]
/// as a material number.
pub const NO_MATERIAL: u32 = crate::ids::NONE;

/// One value of a channel: how it is compared (bit for bit), checked (finite) and written as
/// 4-byte words (the lossless `.pm` form).
pub trait Value: Copy {
    /// Words per value.
    const WORDS: usize;
    /// Whether the two values are the same, bit for bit.
    fn same(&self, other: &Self) -> bool;
    /// Whether every component is finite.
    fn finite(&self) -> bool;
    /// The value as words.
    fn words(&self, out: &mut Vec<u32>);
    /// The value from `Self::WORDS` words; `None` when they are not one.
    fn from_words(words: &[u32]) -> Option<Self>;
}

impl<const N: usize> Value for [f32; N] {
    const WORDS: usize = N;
    fn same(&self, other: &Self) -> bool {
        self.map(f32::to_bits) == other.map(f32::to_bits)
    }
    fn finite(&self) -> bool {
        self.iter().all(|c| c.is_finite())
    }
    fn words(&self, out: &mut Vec<u32>) {
        out.extend(self.map(f32::to_bits));
    }
    fn from_words(words: &[u32]) -> Option<Self> {
        let v: [f32; N] = std::array::from_fn(|k| f32::from_bits(words[k]));
        v.finite().then_some(v)
    }
}

impl Value for [u16; 4] {
    const WORDS: usize = 4;
    fn same(&self, other: &Self) -> bool {
        self == other
    }
    fn finite(&self) -> bool {
        true
    }
    fn words(&self, out: &mut Vec<u32>) {
        out.extend(self.map(u32::from));
    }
    fn from_words(words: &[u32]) -> Option<Self> {
        let mut v = [0u16; 4];
        for (x, &w) in v.iter_mut().zip(words) {
            *x = u16::try_from(w).ok()?;
        }
        Some(v)
    }
}

impl Value for u32 {
    const WORDS: usize = 1;
    fn same(&self, other: &Self) -> bool {
        self == other
    }
    fn finite(&self) -> bool {
        true
    }
    fn words(&self, out: &mut Vec<u32>) {
        out.push(*self);
    }
    fn from_words(words: &[u32]) -> Option<Self> {
        Some(words[0])
    }
}

/// A channel's values, one per corner, in one of the forms a value takes.
#[derive(Debug, Clone, PartialEq)]
pub enum Values {
    /// One float per corner.
    F1(Vec<[f32; 1]>),
    /// Two floats per corner (texture coordinates).
    F2(Vec<[f32; 2]>),
    /// Three floats per corner (normals).
    F3(Vec<[f32; 3]>),
    /// Four floats per corner (tangents, colours, weights).
    F4(Vec<[f32; 4]>),
    /// Four unsigned 16-bit integers per corner (joints).
    U16x4(Vec<[u16; 4]>),
    /// One unsigned 32-bit integer per corner (materials, ids).
    U32(Vec<u32>),
}

/// Runs `$body` with `$v` bound to the values, whatever their form.
macro_rules! each {
    ($values:expr, $v:ident => $body:expr) => {
        match $values {
            Values::F1($v) => $body,
            Values::F2($v) => $body,
            Values::F3($v) => $body,
            Values::F4($v) => $body,
            Values::U16x4($v) => $body,
            Values::U32($v) => $body,
        }
    };
}

/// Builds values of the same form from `$v`.
macro_rules! each_into {
    ($values:expr, $v:ident => $body:expr) => {
        match $values {
            Values::F1($v) => Values::F1($body),
            Values::F2($v) => Values::F2($body),
            Values::F3($v) => Values::F3($body),
            Values::F4($v) => Values::F4($body),
            Values::U16x4($v) => Values::U16x4($body),
            Values::U32($v) => Values::U32($body),
        }
    };
}

impl Values {
    /// The forms in the order of their codes ([`Values::code`]).
    const CODES: [fn() -> Values; 6] = [
        || Values::F1(Vec::new()),
        || Values::F2(Vec::new()),
        || Values::F3(Vec::new()),
        || Values::F4(Vec::new()),
        || Values::U16x4(Vec::new()),
        || Values::U32(Vec::new()),
    ];

    /// Number of values.
    pub fn len(&self) -> usize {
        each!(self, v => v.len())
    }

    /// Whether there is no value.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The values at `kept` (indices), in that order.
    pub fn pick(&self, kept: impl Iterator<Item = usize>) -> Values {
        each_into!(self, v => kept.map(|k| v[k]).collect())
    }

    /// Whether values `a` and `b` are the same, bit for bit.
    pub fn same(&self, a: usize, b: usize) -> bool {
        each!(self, v => v[a].same(&v[b]))
    }

    /// The first value with a component that is not finite.
    pub fn first_non_finite(&self) -> Option<usize> {
        each!(self, v => {
            // One pass without a branch per value (validation reads every value of every mesh),
            // the position only on failure.
            let all = v.iter().fold(true, |ok, x| ok & x.finite());
            if all { None } else { v.iter().position(|x| !x.finite()) }
        })
    }

    /// Words per value.
    pub fn words_per_value(&self) -> usize {
        fn words<T: Value>(_: &[T]) -> usize {
            T::WORDS
        }
        each!(self, v => words(v))
    }

    /// Value `k` as words (appended to `out`).
    pub fn words(&self, k: usize, out: &mut Vec<u32>) {
        each!(self, v => v[k].words(out))
    }

    /// Appends a value read from words (`words_per_value` of them); false when they are not one
    /// (a non-finite float, a joint over 65 535).
    pub fn push_words(&mut self, words: &[u32]) -> bool {
        fn push<T: Value>(v: &mut Vec<T>, words: &[u32]) -> bool {
            T::from_words(words).map(|x| v.push(x)).is_some()
        }
        each!(self, v => push(v, words))
    }

    /// The form's code, as the `.pm` file names it.
    pub fn code(&self) -> u8 {
        match self {
            Values::F1(_) => 0,
            Values::F2(_) => 1,
            Values::F3(_) => 2,
            Values::F4(_) => 3,
            Values::U16x4(_) => 4,
            Values::U32(_) => 5,
        }
    }

    /// Empty values of the form `code` names; `None` for a code no form has.
    pub fn of_code(code: u8) -> Option<Values> {
        Self::CODES.get(usize::from(code)).map(|empty| empty())
    }

    /// Whether the values are floats (a mean of two is a value).
    pub fn is_float(&self) -> bool {
        matches!(self, Values::F1(_) | Values::F2(_) | Values::F3(_) | Values::F4(_))
    }

    /// Appends `other`'s values, when they have the same form (else nothing).
    pub fn extend(&mut self, other: &Values) {
        match (self, other) {
            (Values::F1(a), Values::F1(b)) => a.extend_from_slice(b),
            (Values::F2(a), Values::F2(b)) => a.extend_from_slice(b),
            (Values::F3(a), Values::F3(b)) => a.extend_from_slice(b),
            (Values::F4(a), Values::F4(b)) => a.extend_from_slice(b),
            (Values::U16x4(a), Values::U16x4(b)) => a.extend_from_slice(b),
            (Values::U32(a), Values::U32(b)) => a.extend_from_slice(b),
            _ => {}
        }
    }

    /// Values `(x, y)` per pair: their mean for floats (`x` itself where `x == y`), `x`'s for
    /// integers.
    pub fn means(&self, pairs: impl Iterator<Item = (usize, usize)>) -> Values {
        match self {
            Values::F1(v) => Values::F1(pairs.map(|e| mean(v, e)).collect()),
            Values::F2(v) => Values::F2(pairs.map(|e| mean(v, e)).collect()),
            Values::F3(v) => Values::F3(pairs.map(|e| mean(v, e)).collect()),
            Values::F4(v) => Values::F4(pairs.map(|e| mean(v, e)).collect()),
            Values::U16x4(v) => Values::U16x4(pairs.map(|(x, _)| v[x]).collect()),
            Values::U32(v) => Values::U32(pairs.map(|(x, _)| v[x]).collect()),
        }
    }
}

/// The mean of values `x` and `y` (`x` itself when they are one).
pub(crate) fn mean<const N: usize>(values: &[[f32; N]], (x, y): (usize, usize)) -> [f32; N] {
    if x == y { values[x] } else { std::array::from_fn(|k| 0.5 * (values[x][k] + values[y][k])) }
}

/// One attribute: what it means and its values, one per corner.
#[derive(Debug, Clone, PartialEq)]
pub struct Channel {
    /// What the values mean.
    pub semantic: Semantic,
    /// The values.
    pub values: Values,
}

/// Per-corner attributes read from a file (texture coordinates with their seams, split normals,
/// colours, skins, materials, custom values), as channels.
///
/// Each channel holds one value per triangle corner: `3 * triangles.len()` values, in triangle
/// order, so a vertex on a seam has different values in the faces on either side. Reading,
/// writing, cleaning, converting, simplifying, the progressive mesh and refinement keep them (a
/// seam vertex collapses only along its seam; subdivision interpolates them per face).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CornerAttributes {
    /// The channels, at most one per semantic, in the order of [`Semantic`].
    channels: Vec<Channel>,
    /// True when texture coordinates have v pointing down from the image's top-left corner, as
    /// glTF has them (so that a glTF read and written again keeps its values bit for bit); writers
    /// of the other convention (OBJ, PLY, OpenGL: v up from the bottom-left) write 1 − v.
    pub uv_origin_top: bool,
    /// The materials, textures and images that the material channel refers to, as read (shared,
    /// not copied, by every mesh made from this one).
    pub library: Option<std::sync::Arc<MaterialLibrary>>,
}

/// Typed access to the channels the engine knows: `$get` reads, `$get_mut` changes values in
/// place, `$set` puts (or with `None` removes) the channel.
macro_rules! typed {
    ($($(#[$doc:meta])* $get:ident, $get_mut:ident, $set:ident: $semantic:expr, $form:ident, $t:ty;)*) => {
        impl CornerAttributes {
            $(
                $(#[$doc])*
                pub fn $get(&self) -> Option<&Vec<$t>> {
                    match self.channel(&$semantic) {
                        Some(Values::$form(v)) => Some(v),
                        _ => None,
                    }
                }

                #[doc = concat!("[`CornerAttributes::", stringify!($get), "`], to change in place.")]
                pub fn $get_mut(&mut self) -> Option<&mut Vec<$t>> {
                    match self.channel_mut(&$semantic) {
                        Some(Values::$form(v)) => Some(v),
                        _ => None,
                    }
                }

                #[doc = concat!("Sets (or with `None` removes) [`CornerAttributes::", stringify!($get), "`].")]
                pub fn $set(&mut self, values: Option<Vec<$t>>) {
                    self.set($semantic, values.map(Values::$form));
                }
            )*
        }
    };
}

typed! {
    /// Normals per corner.
    normals, normals_mut, set_normals: Semantic::Normal, F3, [f32; 3];
    /// Texture coordinates per corner (set 0), with the origin `uv_origin_top` says.
    uvs, uvs_mut, set_uvs: Semantic::TexCoord(0), F2, [f32; 2];
    /// A second set of texture coordinates per corner (glTF TEXCOORD_1: a light map, an occlusion
    /// map), with the same origin as `uvs`.
    uvs1, uvs1_mut, set_uvs1: Semantic::TexCoord(1), F2, [f32; 2];
    /// Tangents per corner (glTF TANGENT).
    tangents, tangents_mut, set_tangents: Semantic::Tangent, F4, [f32; 4];
    /// Colours per corner, RGBA in [0, 1].
    colors, colors_mut, set_colors: Semantic::Color(0), F4, [f32; 4];
    /// Skinning per corner (glTF JOINTS_0). Present exactly when `weights` is.
    joints, joints_mut, set_joints: Semantic::Joints(0), U16x4, [u16; 4];
    /// Skinning per corner (glTF WEIGHTS_0): how much each of `joints` moves the vertex.
    weights, weights_mut, set_weights: Semantic::Weights(0), F4, [f32; 4];
    /// Material per corner: an index into `library`'s materials, or [`NO_MATERIAL`].
    materials, materials_mut, set_materials: Semantic::Material, U32, u32;
}

/// Vertices split by attributes: see [`CornerAttributes::wedges`].
#[derive(Debug, Clone, PartialEq)]
pub struct Wedges {
    /// Per output vertex: a corner that has it, or (when `identity`) the vertex itself.
    pub source: Vec<usize>,
    /// Per corner (3 per triangle): its output vertex.
    pub corner_vertex: Vec<u32>,
    /// True when there are no attributes and the output vertices are the mesh's own.
    pub identity: bool,
}

impl Wedges {
    /// The mesh vertex of output vertex `i`.
    pub fn vertex(&self, triangles: &[[u32; 3]], i: usize) -> usize {
        let k = self.source[i];
        if self.identity { k } else { triangles[k / 3][k % 3] as usize }
    }
}

impl CornerAttributes {
    /// The channels, in the order of [`Semantic`].
    pub fn channels(&self) -> &[Channel] {
        &self.channels
    }

    /// The values of the channel `semantic` names, if there is one.
    pub fn channel(&self, semantic: &Semantic) -> Option<&Values> {
        self.channels.iter().find(|c| c.semantic == *semantic).map(|c| &c.values)
    }

    /// [`CornerAttributes::channel`], to change in place.
    pub fn channel_mut(&mut self, semantic: &Semantic) -> Option<&mut Values> {
        self.channels.iter_mut().find(|c| c.semantic == *semantic).map(|c| &mut c.values)
    }

    /// Sets the channel `semantic` to `values` (in its place in the order), or removes it.
    pub fn set(&mut self, semantic: Semantic, values: Option<Values>) {
        match (self.channels.binary_search_by(|c| c.semantic.cmp(&semantic)), values) {
            (Ok(i), Some(values)) => self.channels[i].values = values,
            (Ok(i), None) => {
                self.channels.remove(i);
            }
            (Err(i), Some(values)) => self.channels.insert(i, Channel { semantic, values }),
            (Err(_), None) => {}
        }
    }

    /// Removes every channel `keep` says no to.
    pub fn retain(&mut self, keep: impl FnMut(&Channel) -> bool) {
        self.channels.retain(keep);
    }

    /// What the input had that is not carried ([`MaterialLibrary::not_carried`]): a warning, or
    /// `None` when nothing is left out.
    pub fn not_carried_warning(&self) -> Option<String> {
        let list = &self.library.as_ref()?.not_carried;
        (!list.is_empty()).then(|| format!("the input's {} are not carried: the result has none", list.join(", ")))
    }

    /// What every command that writes a result says of its input: [`Self::not_carried_warning`],
    /// [`Self::passed_through_note`] and what the reader mended ([`MaterialLibrary::mended`]).
    pub fn input_warnings(&self) -> impl Iterator<Item = String> {
        let mended = self.library.as_ref().map(|l| l.mended.clone()).unwrap_or_default();
        self.not_carried_warning().into_iter().chain(self.passed_through_note()).chain(mended)
    }

    /// What the input had that is carried as it was ([`MaterialLibrary::other_primitives`]): a
    /// note, or `None` when there is none.
    pub fn passed_through_note(&self) -> Option<String> {
        let n = self.library.as_ref()?.other_primitives.len();
        (n > 0).then(|| {
            format!("the input's {n} point and line primitive(s) are carried as they were into a glTF result (only triangles are simplified or refined)")
        })
    }

    /// Names of the channels present ([`Semantic::name`]), in their order.
    pub fn names(&self) -> Vec<&str> {
        self.channels.iter().map(|c| c.semantic.name()).collect()
    }

    /// Number of values each channel holds (the first one's; 0 without any).
    pub fn value_count(&self) -> usize {
        self.channels.first().map_or(0, |c| c.values.len())
    }

    /// Whether there is no attribute.
    pub fn is_empty(&self) -> bool {
        self.channels.is_empty()
    }

    /// The channels but the material: the values that split a vertex in a format without
    /// materials.
    fn value_channels(&self) -> impl Iterator<Item = &Channel> + Clone {
        self.channels.iter().filter(|c| c.semantic != Semantic::Material)
    }

    /// Whether there is a value besides the material.
    fn has_values(&self) -> bool {
        self.value_channels().next().is_some()
    }

    /// The attributes of the corners `kept` (corner indices), in that order.
    pub fn pick(&self, kept: impl Iterator<Item = usize> + Clone) -> CornerAttributes {
        let channels = self
            .channels
            .iter()
            .map(|c| Channel { semantic: c.semantic.clone(), values: c.values.pick(kept.clone()) })
            .collect();
        CornerAttributes { channels, uv_origin_top: self.uv_origin_top, library: self.library.clone() }
    }

    /// A number per corner of `triangles` (over `vertex_count` vertices): two corners of the same
    /// vertex have the same number exactly when [`CornerAttributes::same`] holds for them (the
    /// number is the first such corner). Comparing two numbers is what a simplifier asks millions
    /// of times.
    pub fn value_ids(&self, triangles: &[[u32; 3]], vertex_count: usize) -> Vec<u32> {
        self.row_ids(triangles, vertex_count, true)
    }

    /// [`CornerAttributes::value_ids`], the materials left out unless `with_materials`.
    fn row_ids(&self, triangles: &[[u32; 3]], vertex_count: usize, with_materials: bool) -> Vec<u32> {
        let compared: Vec<&Values> = self
            .channels
            .iter()
            .filter(|c| with_materials || c.semantic != Semantic::Material)
            .map(|c| &c.values)
            .collect();
        let same = |a: usize, b: usize| compared.iter().all(|v| v.same(a, b));
        // Per vertex, the corners with distinct values met so far (a chain through `next`): a
        // corner takes the number of the first one with its values, else starts a new one. (The
        // values are compared where they are: a copy of them as rows of words cost more than the
        // comparisons, about one per corner.)
        let corner_count = 3 * triangles.len();
        let mut first = vec![u32::MAX; vertex_count];
        let mut next = vec![u32::MAX; corner_count];
        let mut ids = vec![0u32; corner_count];
        for (k, &v) in triangles.iter().flatten().enumerate() {
            let mut r = first[v as usize];
            let mut last = u32::MAX;
            while r != u32::MAX && !same(r as usize, k) {
                last = r;
                r = next[r as usize];
            }
            if r == u32::MAX {
                r = k as u32;
                if last == u32::MAX {
                    first[v as usize] = r;
                } else {
                    next[last as usize] = r;
                }
            }
            ids[k] = r;
        }
        ids
    }

    /// Whether corners `a` and `b` carry the same attributes, bit for bit.
    pub fn same(&self, a: usize, b: usize) -> bool {
        self.channels.iter().all(|c| c.values.same(a, b))
    }

    /// [`CornerAttributes::same`] for every attribute but the normal (a double-sided sheet's back
    /// may carry its front's values with the normals turned round).
    pub fn same_but_normals(&self, a: usize, b: usize) -> bool {
        self.channels.iter().filter(|c| c.semantic != Semantic::Normal).all(|c| c.values.same(a, b))
    }

    /// Splits the mesh's vertices where their corners differ, for formats with one value per
    /// vertex (PLY, glTF, GPU buffers): one output vertex per distinct (vertex, attributes) pair.
    /// Returns, per output vertex, a corner that has it (so its vertex and values), and per corner
    /// its output vertex. Without attributes the vertices stay as they are (every vertex, used or
    /// not; `source` then holds vertex indices, marked by [`Wedges::identity`]).
    pub fn wedges(&self, triangles: &[[u32; 3]], vertex_count: usize) -> Wedges {
        self.split_vertices(triangles, vertex_count, true)
    }

    /// [`CornerAttributes::wedges`] for a format without materials (PLY, the contract's `Mesh`):
    /// vertices split by their values only.
    pub fn value_wedges(&self, triangles: &[[u32; 3]], vertex_count: usize) -> Wedges {
        self.split_vertices(triangles, vertex_count, false)
    }

    fn split_vertices(&self, triangles: &[[u32; 3]], vertex_count: usize, by_material: bool) -> Wedges {
        let splits = if by_material { !self.is_empty() } else { self.has_values() };
        if !splits {
            return Wedges {
                source: (0..vertex_count).collect(),
                corner_vertex: triangles.iter().flatten().copied().collect(),
                identity: true,
            };
        }
        // One output vertex per corner that is the first of its vertex with its values, in the
        // mesh's vertex order (a vertex's copies in the order its corners first use them), so that a
        // reader joining the copies again (`Mesh::join_cut_seams`) numbers the vertices as they
        // were: a mesh written and read back simplifies as it did before.
        let ids = self.row_ids(triangles, vertex_count, by_material);
        let vertex_of = |k: usize| triangles[k / 3][k % 3];
        let mut source: Vec<usize> = (0..ids.len()).filter(|&k| ids[k] as usize == k).collect();
        source.sort_by_key(|&k| (vertex_of(k), k));
        let mut rank = vec![0u32; ids.len()];
        for (r, &k) in source.iter().enumerate() {
            rank[k] = r as u32;
        }
        let corner_vertex = ids.iter().map(|&id| rank[id as usize]).collect();
        Wedges { source, corner_vertex, identity: false }
    }

    /// The texture coordinates with v pointing down (`top` true, glTF) or up (OBJ, PLY), flipped
    /// (v → 1 − v) when stored the other way.
    pub fn uvs_with_origin(&self, top: bool) -> Option<Cow<'_, [[f32; 2]]>> {
        self.uvs().map(|uvs| self.with_origin(uvs, top))
    }

    /// [`CornerAttributes::uvs_with_origin`] for the second set.
    pub fn uvs1_with_origin(&self, top: bool) -> Option<Cow<'_, [[f32; 2]]>> {
        self.uvs1().map(|uvs| self.with_origin(uvs, top))
    }

    fn with_origin<'a>(&self, uvs: &'a [[f32; 2]], top: bool) -> Cow<'a, [[f32; 2]]> {
        if top == self.uv_origin_top {
            Cow::Borrowed(uvs)
        } else {
            Cow::Owned(uvs.iter().map(|&[u, v]| [u, 1.0 - v]).collect())
        }
    }

    /// Checks the joints and weights: both or neither, one per value, and every joint one of the
    /// rig's skin (a `.pm` file's value table is checked with it too).
    pub(crate) fn check_skin(&self, count: usize) -> Result<(), MeshError> {
        match self.joints() {
            Some(joints) if joints.len() != count => {
                return Err(MeshError::InvalidParameter {
                    name: "joints",
                    reason: format!("{} per-corner values for {count} corners", joints.len()),
                });
            }
            Some(_) if self.weights().is_none() => {
                return Err(MeshError::InvalidParameter { name: "weights", reason: "joints without weights".into() });
            }
            None if self.weights().is_some() => {
                return Err(MeshError::InvalidParameter { name: "joints", reason: "weights without joints".into() });
            }
            _ => {}
        }
        if let Some(joints) = self.joints() {
            let rig = self.library.as_ref().and_then(|l| l.rig.as_ref());
            let known = rig.map_or(0, Rig::joint_count);
            if let Some(corner) = joints.iter().position(|j| j.iter().any(|&x| x as usize >= known)) {
                let reason = match rig {
                    None => "joints without a skin to refer to".to_string(),
                    Some(_) => format!(
                        "corner {corner} (face {}) names joint {}; the skin has {known}",
                        corner / 3,
                        joints[corner].iter().max().copied().unwrap_or(0)
                    ),
                };
                return Err(MeshError::InvalidParameter { name: "joints", reason });
            }
        }
        Ok(())
    }

    /// Checks one value per corner in every channel and finite values, the skin and the
    /// materials; errors name the channel and the corner.
    pub(crate) fn check(&self, corner_count: usize) -> Result<(), MeshError> {
        for c in &self.channels {
            // Errors name the engine's own channels by a static name; a custom one by "custom".
            let name = match &c.semantic {
                Semantic::Custom(_) => "custom",
                s => KNOWN_NAMES.iter().find(|&&n| n == s.name()).copied().unwrap_or("attribute"),
            };
            let named = |reason: String| MeshError::InvalidParameter {
                name,
                reason: match &c.semantic {
                    Semantic::Custom(custom) => format!("{custom}: {reason}"),
                    _ => reason,
                },
            };
            if c.values.len() != corner_count {
                return Err(named(format!("{} per-corner values for {corner_count} corners", c.values.len())));
            }
            if let Some(corner) = c.values.first_non_finite() {
                return Err(named(format!("corner {corner} (face {}) has a non-finite value", corner / 3)));
            }
        }
        self.check_skin(corner_count)?;
        self.check_materials()?;
        if let Some(library) = &self.library {
            for (i, other) in library.other_primitives.iter().enumerate() {
                other.check(library.materials.len()).map_err(|reason| MeshError::InvalidParameter {
                    name: "other_primitives",
                    reason: format!("point or line primitive {i}: {reason}"),
                })?;
            }
        }
        Ok(())
    }

    /// Checks that a face's corners have one material, and that it is one the library has.
    fn check_materials(&self) -> Result<(), MeshError> {
        let Some(materials) = self.materials() else { return Ok(()) };
        let reason = if let Some(face) = materials.chunks(3).position(|m| m[0] != m[1] || m[1] != m[2]) {
            Some(format!("face {face} has corners of different materials"))
        } else {
            let known = self.library.as_ref().map_or(0, |l| l.materials.len());
            materials
                .iter()
                .position(|&m| m != NO_MATERIAL && m as usize >= known)
                .map(|corner| format!("face {} names material {}; there are {known}", corner / 3, materials[corner]))
        };
        match reason {
            Some(reason) => Err(MeshError::InvalidParameter { name: "material", reason }),
            None => Ok(()),
        }
    }
}

/// The names of the engine's own channels, as errors name them (a `&'static str`).
const KNOWN_NAMES: [&str; 8] = ["normal", "uv", "uv1", "tangent", "color", "joints", "weights", "material"];
