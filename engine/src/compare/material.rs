//! What a pixel of a render shows: the face's base colour (its material's factor × its
//! base-colour texture, sampled bilinearly with glTF's REPEAT wrapping, × the vertex colour), lit
//! by a headlight with the file's normals.

use glam::DVec3;

use crate::library::{ImageSource, MaterialLibrary};
use crate::mesh::{Mesh, NO_MATERIAL};

/// Light that reaches a face seen edge-on (the rest of the light is the headlight's Lambert term).
const AMBIENT: f64 = 0.15;

/// A material as a render draws it.
#[derive(Debug, Clone)]
struct Paint {
    factor: [f64; 4],
    /// The base-colour texture: its image (an index into [`Palette::images`]) and its texture
    /// coordinate set.
    texture: Option<(usize, u8)>,
}

/// The materials and decoded images of a mesh's library.
#[derive(Debug, Clone, Default)]
pub(crate) struct Palette {
    paints: Vec<Paint>,
    images: Vec<Option<image::RgbaImage>>,
    /// Images that could not be read (drawn white), said in the report.
    pub notes: Vec<String>,
}

impl Palette {
    /// The palette of `library` (none: every face white).
    pub fn of(library: Option<&MaterialLibrary>) -> Palette {
        let Some(library) = library else { return Palette::default() };
        let mut notes = Vec::new();
        let images = library
            .images
            .iter()
            .enumerate()
            .map(|(i, image)| match decode(&image.source) {
                Ok(decoded) => Some(decoded),
                Err(reason) => {
                    notes.push(format!("image {i} could not be read ({reason}): its faces are drawn without it"));
                    None
                }
            })
            .collect();
        let paints = library.materials.iter().map(|m| paint(m, library)).collect();
        Palette { paints, images, notes }
    }

    /// The colour (RGB in [0, 1]) of `surface`'s face `f` at weights `w`, lit from `light`
    /// (towards the viewer).
    pub fn shade(&self, surface: &Surface<'_>, f: usize, w: [f32; 3], light: DVec3) -> [f64; 3] {
        let corners = [3 * f, 3 * f + 1, 3 * f + 2];
        let mix = |values: &[[f32; 4]]| -> [f64; 4] {
            std::array::from_fn(|k| corners.iter().zip(w).map(|(&i, w)| f64::from(values[i][k] * w)).sum())
        };
        let material = surface.materials.map_or(NO_MATERIAL, |m| m[3 * f]);
        let paint = self.paints.get(material as usize);
        let mut colour = paint.map_or([1.0; 4], |p| p.factor);
        if let Some((image, set)) = paint.and_then(|p| p.texture)
            && let (Some(Some(image)), Some(uvs)) = (self.images.get(image), &surface.uvs[usize::from(set)])
        {
            let u: f64 = corners.iter().zip(w).map(|(&i, w)| f64::from(uvs[i][0] * w)).sum();
            let v: f64 = corners.iter().zip(w).map(|(&i, w)| f64::from(uvs[i][1] * w)).sum();
            let texel = sample(image, u, v);
            colour = std::array::from_fn(|k| colour[k] * texel[k]);
        }
        if let Some(colors) = surface.colors {
            let vertex = mix(colors);
            colour = std::array::from_fn(|k| colour[k] * vertex[k]);
        }
        let normal = match surface.normals {
            Some(n) => corners.iter().zip(w).map(|(&i, w)| DVec3::from(n[i].map(f64::from)) * f64::from(w)).sum(),
            None => surface.mesh.face_area_vector(f),
        };
        let lambert = normal.normalize_or_zero().dot(light).abs();
        let light = AMBIENT + (1.0 - AMBIENT) * lambert;
        [0, 1, 2].map(|k| (colour[k] * light).clamp(0.0, 1.0))
    }
}

/// What the renders of a mesh read per pixel, looked up once for every view: its channels, and its
/// two texture coordinate sets with v down from the image's top, as glTF samples them (flipped
/// once when the mesh stores them the other way).
pub(crate) struct Surface<'a> {
    pub mesh: &'a Mesh,
    uvs: [Option<std::borrow::Cow<'a, [[f32; 2]]>>; 2],
    materials: Option<&'a Vec<u32>>,
    colors: Option<&'a Vec<[f32; 4]>>,
    normals: Option<&'a Vec<[f32; 3]>>,
}

impl<'a> Surface<'a> {
    /// The surface of `mesh`.
    pub fn of(mesh: &'a Mesh) -> Surface<'a> {
        let c = &mesh.corners;
        Surface {
            mesh,
            uvs: [c.uvs_with_origin(true), c.uvs1_with_origin(true)],
            materials: c.materials(),
            colors: c.colors(),
            normals: c.normals(),
        }
    }
}

/// A glTF material's base colour factor and texture.
fn paint(material: &serde_json::Value, library: &MaterialLibrary) -> Paint {
    let pbr = &material["pbrMetallicRoughness"];
    let factor = match pbr["baseColorFactor"].as_array() {
        Some(f) if f.len() == 4 => std::array::from_fn(|k| f[k].as_f64().unwrap_or(1.0)),
        _ => [1.0; 4],
    };
    let texture = pbr["baseColorTexture"]["index"].as_u64().and_then(|t| {
        let source = library.textures.get(t as usize)?["source"].as_u64()?;
        let set = pbr["baseColorTexture"]["texCoord"].as_u64().unwrap_or(0);
        (set <= 1).then_some((source as usize, set as u8))
    });
    Paint { factor, texture }
}

/// An image's pixels, from its bytes or its file.
fn decode(source: &ImageSource) -> Result<image::RgbaImage, String> {
    let bytes = match source {
        ImageSource::Bytes(bytes) => std::borrow::Cow::Borrowed(bytes),
        ImageSource::File(path) => std::borrow::Cow::Owned(std::fs::read(path).map_err(|e| e.to_string())?),
        ImageSource::Uri(uri) => return Err(format!("{uri} is not at hand")),
    };
    let image = image::load_from_memory(&bytes).map_err(|e| e.to_string())?;
    Ok(image.to_rgba8())
}

/// The image's colour at texture coordinates `(u, v)` (v down from the top, as glTF has them),
/// bilinear, repeating, RGBA in [0, 1].
fn sample(image: &image::RgbaImage, u: f64, v: f64) -> [f64; 4] {
    let (w, h) = (image.width() as i64, image.height() as i64);
    if w == 0 || h == 0 || !(u.is_finite() && v.is_finite()) {
        return [1.0; 4];
    }
    let x = u * w as f64 - 0.5;
    let y = v * h as f64 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let texel = |x: i64, y: i64| image.get_pixel(x.rem_euclid(w) as u32, y.rem_euclid(h) as u32).0;
    let (x0, y0) = (x0 as i64, y0 as i64);
    let corners = [(texel(x0, y0), (1.0 - fx) * (1.0 - fy)), (texel(x0 + 1, y0), fx * (1.0 - fy))];
    let corners = corners.into_iter().chain([(texel(x0, y0 + 1), (1.0 - fx) * fy), (texel(x0 + 1, y0 + 1), fx * fy)]);
    let mut out = [0.0; 4];
    for (t, weight) in corners {
        for k in 0..4 {
            out[k] += f64::from(t[k]) / 255.0 * weight;
        }
    }
    out
}
