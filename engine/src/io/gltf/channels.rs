//! The attributes of a glTF primitive beyond the ones the engine gives a meaning to, read into
//! channels: texture coordinate sets past the second, colour sets past the first, and
//! application-specific attributes (`_NAME`). They travel as the other channels do and are
//! written back under their glTF names (`super::write`).

use super::accessor::{any_floats, same_count};
use crate::mesh::{Channel, MaterialLibrary, Semantic, Values};

/// Most further attributes a primitive's channels take (in the order the file lists them; the
/// others are said and left out): each is a value per corner, and a file may name one accessor
/// under many names, so that a few bytes would ask for gigabytes.
pub(crate) const MAX_EXTRA_CHANNELS: usize = 16;

/// The channel an attribute beyond the ones the engine gives a meaning to is read into: a third
/// or later TEXCOORD_n, a second or later COLOR_n, or an application-specific attribute (`_NAME`,
/// such as `_FEATURE_ID_0`) of one to four components; `None` for the others.
pub(super) fn extra_channel(semantic: &gltf::Semantic, accessor: &gltf::Accessor) -> Option<Semantic> {
    match semantic {
        gltf::Semantic::TexCoords(k @ 2..=255) => Some(Semantic::TexCoord(*k as u8)),
        gltf::Semantic::Colors(k @ 1..=255) => Some(Semantic::Color(*k as u8)),
        gltf::Semantic::Extras(_) if accessor.dimensions().multiplicity() <= 4 => {
            Some(Semantic::Custom(semantic.to_string()))
        }
        _ => None,
    }
}

/// The primitive's attributes [`extra_channel`] reads, per vertex (`n` of them): values as
/// floats (integers converted as glTF's normalised types are, or to the float they are),
/// colours as RGBA.
pub(super) fn extra_channels<'a, 's, F>(
    primitive: &gltf::Primitive,
    reader: &gltf::mesh::Reader<'a, 's, F>,
    buffers: &[Vec<u8>],
    n: usize,
) -> Result<Vec<Channel>, String>
where
    F: Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>,
{
    let mut out = Vec::new();
    for (semantic, accessor) in primitive.attributes() {
        let Some(channel) = extra_channel(&semantic, &accessor) else { continue };
        if out.len() == MAX_EXTRA_CHANNELS {
            break;
        }
        let name = semantic.to_string();
        let values = match (&channel, accessor.dimensions().multiplicity()) {
            (Semantic::Color(k), _) => Values::F4(
                reader.read_colors(u32::from(*k)).ok_or(format!("{name} cannot be read"))?.into_rgba_f32().collect(),
            ),
            (_, 1) => Values::F1(any_floats::<1>(primitive, &semantic, buffers)?.unwrap_or_default()),
            (_, 2) => Values::F2(any_floats::<2>(primitive, &semantic, buffers)?.unwrap_or_default()),
            (_, 3) => Values::F3(any_floats::<3>(primitive, &semantic, buffers)?.unwrap_or_default()),
            _ => Values::F4(any_floats::<4>(primitive, &semantic, buffers)?.unwrap_or_default()),
        };
        same_count(&name, values.len(), n)?;
        if let Some(vertex) = values.first_non_finite() {
            return Err(format!("{name} of vertex {vertex} is not a finite number"));
        }
        out.push(Channel { semantic: channel, values });
    }
    Ok(out)
}

/// The parts' extra channels ([`extra_channels`], per part with its number of corners in
/// `corner_counts`) joined, each kept when the parts that have it
/// agree on its form: a part without it takes zeros (white for a colour), as for TEXCOORD_0. One
/// of different forms is said and left out.
pub(super) fn merge_extra(
    parts: &[Vec<Channel>],
    corner_counts: &[usize],
    library: &mut MaterialLibrary,
) -> Vec<(Semantic, Values)> {
    let mut semantics: Vec<&Semantic> = Vec::new();
    for c in parts.iter().flatten() {
        if !semantics.contains(&&c.semantic) {
            semantics.push(&c.semantic);
        }
    }
    let mut out = Vec::new();
    for semantic in semantics {
        let mut forms = parts.iter().flatten().filter(|c| c.semantic == *semantic).map(|c| c.values.code());
        let form = forms.next().expect("a part has it");
        if forms.any(|f| f != form) {
            library
                .not_carried
                .push(format!("{} values (of different types in different primitives)", semantic.name()));
            continue;
        }
        let mut all = Values::of_code(form).expect("a form's own code");
        let fill: Vec<u32> = match semantic {
            Semantic::Color(_) => vec![1f32.to_bits(); 4],
            _ => vec![0; all.words_per_value()],
        };
        for (part, &corners) in parts.iter().zip(corner_counts) {
            match part.iter().find(|c| c.semantic == *semantic) {
                Some(c) => all.extend(&c.values),
                None => (0..corners).for_each(|_| {
                    all.push_words(&fill);
                }),
            }
        }
        out.push((semantic.clone(), all));
    }
    out
}
