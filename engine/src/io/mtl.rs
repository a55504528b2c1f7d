//! Wavefront MTL material files, translated into glTF terms ([`MaterialLibrary`]) so that an OBJ
//! written as glTF draws with its materials, and written back from them beside an OBJ
//! ([`write_library`]) so that an OBJ written from any input draws with its materials.
//!
//! Translated: `Kd`, `d` and `map_Kd` (base colour, opacity, base-colour texture), `Ke` and
//! `map_Ke` (emission), `norm` (normal map; `-bm` its scale). Texture statements take their options
//! as they come and a file name that may hold spaces. The other statements without a file (`Ka`,
//! `Ks`, `Ns`, `illum`, `Tr`, ...) are kept as they were in the material's `extras.mtl`, and
//! written back as they were: an OBJ's LOD keeps its whole material (a glTF result leaves them
//! out). The other texture statements (`map_Ks`, `map_Bump`, `bump`, `disp`, ...) are not
//! carried, said: `map_Bump` is a height map to some exporters and a normal map to others. `Tr` is not translated (exporters
//! disagree on whether it means transparency or opacity). A material named by `usemtl` but found
//! in no MTL file keeps its name. The translated statements are written from any input's
//! materials, glTF's among them.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde_json::json;

use crate::mesh::{Image, ImageSource, MaterialLibrary};

/// Largest MTL file read (they are small text files; a larger one is skipped).
const MAX_MTL_BYTES: u64 = 16 << 20;

/// One `newmtl` entry.
#[derive(Default, Clone)]
struct Entry {
    name: String,
    diffuse: Option<[f64; 3]>,
    opacity: Option<f64>,
    texture: Option<String>,
    emissive: Option<[f64; 3]>,
    emissive_texture: Option<String>,
    /// The normal map's file and its `-bm` scale.
    normal_texture: Option<(String, Option<f64>)>,
    /// The statements without a file that are not translated, as they were.
    kept: Vec<String>,
    /// The keywords of the texture statements that are not carried.
    dropped: Vec<String>,
}

/// The materials `names` (in `usemtl` order) as found in the `mtllib` files `libraries`, looked
/// for in `folder`.
pub(crate) fn library(names: &[String], libraries: &[String], folder: Option<&Path>) -> MaterialLibrary {
    let mut entries: Vec<Entry> = Vec::new();
    if let Some(folder) = folder {
        for line in libraries {
            // `mtllib a.mtl b.mtl`, or one file name with spaces.
            let whole = folder.join(line);
            let files: Vec<std::path::PathBuf> = if whole.is_file() {
                vec![whole]
            } else {
                line.split_ascii_whitespace().map(|f| folder.join(f)).collect()
            };
            for file in files {
                entries.extend(read_entries(&file));
            }
        }
    }
    let mut library = MaterialLibrary::default();
    let mut texture_files: Vec<String> = Vec::new();
    let mut texture = |file: &String| {
        let index = texture_files.iter().position(|f| f == file).unwrap_or_else(|| {
            texture_files.push(file.clone());
            texture_files.len() - 1
        });
        json!({ "index": index })
    };
    let mut dropped: Vec<String> = Vec::new();
    for name in names {
        let entry = entries
            .iter()
            .find(|e| e.name == *name)
            .cloned()
            .unwrap_or(Entry { name: name.clone(), ..Default::default() });
        let opacity = entry.opacity.unwrap_or(1.0).clamp(0.0, 1.0);
        // A texture is modulated by white: exporters write Kd beside map_Kd inconsistently.
        let colour = if entry.texture.is_some() { [1.0; 3] } else { entry.diffuse.unwrap_or([1.0; 3]) };
        let mut pbr = json!({
            "baseColorFactor": [colour[0], colour[1], colour[2], opacity],
            "metallicFactor": 0.0,
            "roughnessFactor": 1.0,
        });
        if let Some(file) = &entry.texture {
            pbr["baseColorTexture"] = texture(file);
        }
        let mut material = json!({ "name": entry.name, "pbrMetallicRoughness": pbr });
        if opacity < 1.0 {
            material["alphaMode"] = json!("BLEND");
        }
        // An emissive texture without `Ke` is drawn as it is (glTF multiplies it by the factor).
        let emissive = entry.emissive.or(entry.emissive_texture.as_ref().map(|_| [1.0; 3]));
        if let Some(e) = emissive.filter(|e| e.iter().any(|&c| c > 0.0)) {
            material["emissiveFactor"] = json!(e.map(|c| c.clamp(0.0, 1.0)));
        }
        if let Some(file) = &entry.emissive_texture {
            material["emissiveTexture"] = texture(file);
        }
        if let Some((file, scale)) = &entry.normal_texture {
            material["normalTexture"] = texture(file);
            if let Some(scale) = scale {
                material["normalTexture"]["scale"] = json!(scale);
            }
        }
        if !entry.kept.is_empty() {
            material["extras"] = json!({ "mtl": entry.kept });
        }
        for keyword in entry.dropped {
            if !dropped.contains(&keyword) {
                dropped.push(keyword);
            }
        }
        library.materials.push(material);
    }
    if !dropped.is_empty() {
        library.not_carried.push(format!("MTL texture statements {}", dropped.join(", ")));
    }
    for (index, file) in texture_files.iter().enumerate() {
        library.textures.push(json!({ "source": index }));
        let source = match folder {
            Some(folder) => ImageSource::File(folder.join(file)),
            None => ImageSource::Uri(file.replace(' ', "%20")),
        };
        let mime_type = match Path::new(file).extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase) {
            Some(e) if e == "png" => Some("image/png".to_string()),
            Some(e) if e == "jpg" || e == "jpeg" => Some("image/jpeg".to_string()),
            _ => None,
        };
        library.images.push(Image { json: json!({ "name": file }), source, mime_type });
    }
    library
}

/// Writes `library`'s materials as the MTL file `path`: per material its name (as `usemtl` names
/// it), `Kd` and `d` from its base colour, `map_Kd` for its base-colour texture, `Ke` and `map_Ke`
/// for its emission, `norm` for its normal map, and the statements an MTL input had that are not
/// translated (its `extras.mtl`). Each such image is put beside the file so that the OBJ draws
/// without the input's folder: an image file already in that folder is named as it is; one
/// elsewhere, or one held in memory (from a GLB or a data URI), is written there under its own
/// name (`STEM_NAME` where a different file has that name, `STEM` the MTL file's stem); one that
/// cannot be read is named by its path relative to the folder, as the input had it.
pub(crate) fn write_library(path: &Path, library: &MaterialLibrary) -> std::io::Result<()> {
    let folder = super::files::folder_of(path);
    let stem = path.file_stem().map_or("materials".into(), |s| s.to_string_lossy().into_owned());
    let mut placed: Vec<Option<String>> = vec![None; library.images.len()];
    let mut written: Vec<String> = Vec::new();
    let mut text = String::from("# meshlod\n");
    let finite = |v: &serde_json::Value| v.as_f64().filter(|x| x.is_finite());
    for (index, material) in library.materials.iter().enumerate() {
        // The file name the MTL gives the image of texture reference `info`, the image placed.
        let mut image_of = |info: &serde_json::Value| -> std::io::Result<Option<String>> {
            let Some(i) = info["index"]
                .as_u64()
                .and_then(|t| library.textures.get(t as usize))
                .and_then(|t| t["source"].as_u64())
                .map(|i| i as usize)
                .filter(|&i| i < library.images.len())
            else {
                return Ok(None);
            };
            if placed[i].is_none() {
                placed[i] = Some(place_image(folder, &stem, i, &library.images[i], &mut written)?);
            }
            Ok(placed[i].clone())
        };
        // (Writing to a String cannot fail.)
        let _ = writeln!(text, "\nnewmtl {}", one_line(&library.material_name(index as u32)));
        let pbr = &material["pbrMetallicRoughness"];
        let factor = |k: usize| finite(&pbr["baseColorFactor"][k]).unwrap_or(1.0);
        let _ = writeln!(text, "Kd {} {} {}", factor(0), factor(1), factor(2));
        if factor(3) < 1.0 {
            let _ = writeln!(text, "d {}", factor(3));
        }
        if let Some(name) = image_of(&pbr["baseColorTexture"])? {
            let _ = writeln!(text, "map_Kd {name}");
        }
        let emissive = [0, 1, 2].map(|k| finite(&material["emissiveFactor"][k]).unwrap_or(0.0));
        if emissive.iter().any(|&c| c > 0.0) {
            let _ = writeln!(text, "Ke {} {} {}", emissive[0], emissive[1], emissive[2]);
        }
        if let Some(name) = image_of(&material["emissiveTexture"])? {
            let _ = writeln!(text, "map_Ke {name}");
        }
        let normal = &material["normalTexture"];
        if let Some(name) = image_of(normal)? {
            match finite(&normal["scale"]).filter(|&s| s != 1.0) {
                Some(scale) => writeln!(text, "norm -bm {scale} {name}"),
                None => writeln!(text, "norm {name}"),
            }
            .ok();
        }
        for line in material["extras"]["mtl"].as_array().into_iter().flatten().filter_map(|l| l.as_str()) {
            let _ = writeln!(text, "{}", one_line(line));
        }
    }
    std::fs::write(path, text)
}

/// The files an OBJ file refers to, as [`super::write_mesh`] writes them: the MTL files its
/// `mtllib` statements name (before its first vertex) and the textures they name (`map_Kd`,
/// `map_Ke`, `norm`), all in the OBJ's folder. Empty for an OBJ without materials or a file that
/// cannot be read.
pub(crate) fn referenced_files(obj: &Path) -> Vec<PathBuf> {
    use std::io::BufRead as _;
    let folder = super::files::folder_of(obj);
    let Ok(file) = std::fs::File::open(obj) else { return Vec::new() };
    let mut files = Vec::new();
    for line in std::io::BufReader::new(file).lines().map_while(Result::ok) {
        let line = line.trim();
        if let Some(name) = line.strip_prefix("mtllib ") {
            files.push(folder.join(name.trim()));
        } else if !line.is_empty() && !line.starts_with('#') {
            break;
        }
    }
    let mut textures = Vec::new();
    for mtl in &files {
        let folder = super::files::folder_of(mtl);
        for entry in read_entries(mtl) {
            let files = [entry.texture, entry.emissive_texture, entry.normal_texture.map(|(file, _)| file)];
            textures.extend(files.into_iter().flatten().map(|file| folder.join(file)));
        }
    }
    files.extend(textures);
    files
}

/// The name an MTL file in `folder` gives image `index` (see [`write_library`]), the image written
/// there first where it has to be; `written`: the names this library's images took so far.
fn place_image(
    folder: &Path,
    stem: &str,
    index: usize,
    image: &Image,
    written: &mut Vec<String>,
) -> std::io::Result<String> {
    let (bytes, name) = match &image.source {
        ImageSource::Uri(uri) => return Ok(one_line(&uri.replace("%20", " "))),
        ImageSource::File(file) => {
            let name = file.file_name().map_or(format!("image{index}"), |n| n.to_string_lossy().into_owned());
            let here = |p: &Path| std::fs::canonicalize(p).ok();
            if file.parent().and_then(here).is_some_and(|p| Some(p) == here(folder)) && file.is_file() {
                return Ok(one_line(&name));
            }
            match super::files::read_referenced(file) {
                Ok(bytes) => (bytes, name),
                Err(_) => {
                    let relative = super::files::relative_path(file, folder);
                    return Ok(one_line(&relative.unwrap_or_else(|| file.to_string_lossy().into_owned())));
                }
            }
        }
        ImageSource::Bytes(bytes) => {
            let extension = match super::files::sniff_image(bytes).or(image.mime_type.as_deref()) {
                Some("image/png") => "png",
                Some("image/jpeg") => "jpg",
                Some("image/webp") => "webp",
                Some("image/ktx2") => "ktx2",
                _ => "bin",
            };
            let base =
                image.json["name"].as_str().filter(|n| !n.is_empty()).map_or(format!("image{index}"), str::to_string);
            let has_extension = Path::new(&base).extension().is_some_and(|e| e.eq_ignore_ascii_case(extension));
            (bytes.clone(), if has_extension { base } else { format!("{base}.{extension}") })
        }
    };
    // A plain file name: other characters (path separators among them) become `_`. The name
    // itself where that file is free or already holds these bytes (LODs of one asset written to
    // one folder share their textures), else the stem in front, else the index too.
    let clean: String =
        name.chars().map(|c| if c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '_') { c } else { '_' }).collect();
    let candidates = [clean.clone(), format!("{stem}_{clean}"), format!("{stem}_{index}_{clean}")];
    for (k, file) in candidates.iter().enumerate() {
        if written.contains(file) {
            continue;
        }
        let target = folder.join(file);
        let last = k == candidates.len() - 1;
        match std::fs::symlink_metadata(&target) {
            Err(_) => {}
            Ok(meta) if meta.is_file() && super::files::read_referenced(&target).is_ok_and(|held| held == bytes) => {
                written.push(file.clone());
                return Ok(file.clone());
            }
            Ok(meta) if meta.is_file() && last => {}
            Ok(_) => continue,
        }
        std::fs::write(&target, &bytes)?;
        written.push(file.clone());
        return Ok(file.clone());
    }
    Err(std::io::Error::other(format!("no free name for image {index} ('{clean}') beside the MTL file")))
}

/// `text` on one line (an MTL statement ends at the line's end).
pub(super) fn one_line(text: &str) -> String {
    text.replace(['\n', '\r'], " ")
}

/// The `newmtl` entries of MTL file `file`: none when it is missing, not a regular file, or
/// larger than [`MAX_MTL_BYTES`] (they are small text files).
fn read_entries(file: &Path) -> Vec<Entry> {
    let small = std::fs::metadata(file).is_ok_and(|m| m.is_file() && m.len() <= MAX_MTL_BYTES);
    small
        .then(|| std::fs::read(file).ok())
        .flatten()
        .map_or_else(Vec::new, |text| parse(&String::from_utf8_lossy(&text)))
}

/// The `newmtl` entries of an MTL file.
fn parse(text: &str) -> Vec<Entry> {
    let mut entries: Vec<Entry> = Vec::new();
    for line in text.lines() {
        let line = line.trim();
        let mut tokens = line.split_ascii_whitespace();
        let Some(keyword) = tokens.next() else { continue };
        let rest = line[keyword.len()..].trim();
        // Keywords in any case, as three.js reads them (`map_kd` is seen in the wild).
        let lower = keyword.to_ascii_lowercase();
        if lower == "newmtl" {
            entries.push(Entry { name: rest.to_string(), ..Default::default() });
            continue;
        }
        let Some(entry) = entries.last_mut() else { continue };
        let numbers: Vec<f64> = tokens.map_while(|t| t.parse::<f64>().ok()).filter(|x| x.is_finite()).collect();
        let colour = (numbers.len() >= 3).then(|| [numbers[0], numbers[1], numbers[2]]);
        match lower.as_str() {
            "kd" if colour.is_some() => entry.diffuse = colour,
            "d" if !numbers.is_empty() => entry.opacity = Some(numbers[0]),
            "map_kd" => entry.texture = texture_file(rest),
            "ke" if colour.is_some() => entry.emissive = colour,
            "map_ke" => entry.emissive_texture = texture_file(rest),
            "norm" => entry.normal_texture = texture_file(rest).map(|file| (file, bump_scale(rest))),
            // (Translated statements the translation cannot read: a spectral curve, a colour
            // given as XYZ.)
            "kd" | "d" | "ke" => {}
            _ if keyword.starts_with('#') => {}
            _ if lower.starts_with("map_") || matches!(lower.as_str(), "bump" | "disp" | "decal" | "refl") => {
                entry.dropped.push(keyword.to_string());
            }
            _ => entry.kept.push(line.to_string()),
        }
    }
    entries
}

/// A texture statement's `-bm` option (a bump or normal map's scale).
fn bump_scale(rest: &str) -> Option<f64> {
    let tokens: Vec<&str> = rest.split_ascii_whitespace().collect();
    let at = tokens.iter().position(|&t| t == "-bm")?;
    tokens.get(at + 1)?.parse::<f64>().ok().filter(|x| x.is_finite())
}

/// The file name of a texture statement: its options (`-o 0 0 0`, `-clamp on`, `-bm 0.5`, ...)
/// skipped, each with the arguments the MTL format gives it (`-o`, `-s` and `-t` one to three
/// numbers, `-mm` two, the others one), so that a name with spaces is kept whole.
fn texture_file(rest: &str) -> Option<String> {
    let tokens: Vec<&str> = rest.split_ascii_whitespace().collect();
    let mut i = 0;
    while i < tokens.len() && tokens[i].starts_with('-') && tokens[i].len() > 1 {
        let (least, most) = match tokens[i] {
            "-o" | "-s" | "-t" => (1, 3),
            "-mm" => (2, 2),
            _ => (1, 1),
        };
        i += 1;
        let mut taken = 0;
        while taken < most && i < tokens.len() && (taken < least || tokens[i].parse::<f64>().is_ok()) {
            i += 1;
            taken += 1;
        }
    }
    let name = tokens.get(i..).unwrap_or_default().join(" ");
    (!name.is_empty()).then_some(name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_keep_colour_opacity_and_texture() {
        let entries = parse(
            "newmtl a b\nKd 0.5 0.25 1\nd 0.5\nnewmtl tex\nmap_kd -o 0.1 0.2 -clamp on -mm 0 1 -imfchan l my tex.png\n",
        );
        assert_eq!(entries.len(), 2);
        assert_eq!(entries[0].name, "a b");
        assert_eq!(entries[0].diffuse, Some([0.5, 0.25, 1.0]));
        assert_eq!(entries[0].opacity, Some(0.5));
        assert_eq!(entries[1].texture.as_deref(), Some("my tex.png"));
    }

    /// Emission and normal maps are translated, the other statements without a file kept as they
    /// were, the other texture statements said; written back, an MTL file says what it said, its
    /// textures beside it.
    #[test]
    fn a_whole_material_goes_through_and_back() {
        let dir = std::env::temp_dir().join(format!("meshlod-mtl-{}", std::process::id()));
        let out = dir.join("out");
        std::fs::create_dir_all(&out).unwrap();
        let input = "newmtl hull\nKa 0.2 0.2 0.2\nKd 0.5 0.5 0.5\nKs 1 1 1\nNs 96\nillum 2\n\
            Ke 0.25 0.5 0\nmap_Ke glow.png\nnorm -bm 0.5 normal map.png\nmap_Bump height.png\nmap_Ks spec.png\n";
        std::fs::write(dir.join("in.mtl"), input).unwrap();
        for file in ["glow.png", "normal map.png"] {
            std::fs::write(dir.join(file), file.as_bytes()).unwrap();
        }
        let library = library(&["hull".into()], &["in.mtl".into()], Some(&dir));
        let material = &library.materials[0];
        assert_eq!(material["emissiveFactor"], json!([0.25, 0.5, 0.0]));
        assert_eq!(material["emissiveTexture"]["index"], 0);
        assert_eq!(
            (&material["normalTexture"]["index"], &material["normalTexture"]["scale"]),
            (&json!(1), &json!(0.5))
        );
        assert_eq!(material["extras"]["mtl"], json!(["Ka 0.2 0.2 0.2", "Ks 1 1 1", "Ns 96", "illum 2"]));
        assert_eq!(library.not_carried, ["MTL texture statements map_Bump, map_Ks"]);
        write_library(&out.join("lod.mtl"), &library).unwrap();
        let back = std::fs::read_to_string(out.join("lod.mtl")).unwrap();
        for line in
            ["Kd 0.5 0.5 0.5", "Ke 0.25 0.5 0", "map_Ke glow.png", "norm -bm 0.5 normal_map.png", "Ks 1 1 1", "illum 2"]
        {
            assert!(back.lines().any(|l| l == line), "'{line}' in:\n{back}");
        }
        assert_eq!(std::fs::read(out.join("normal_map.png")).unwrap(), b"normal map.png");
        assert!(out.join("glow.png").is_file() && !back.contains("map_Bump"));
        // An OBJ naming that MTL file refers to it and to both textures (a batch checks them).
        std::fs::write(out.join("lod.obj"), "# meshlod\nmtllib lod.mtl\nv 0 0 0\n").unwrap();
        let mut referred = referenced_files(&out.join("lod.obj"));
        referred.sort();
        assert_eq!(referred, ["glow.png", "lod.mtl", "normal_map.png"].map(|f| out.join(f)));
        // A glTF result keeps the translation and leaves the MTL statements out.
        let mut mesh = crate::procedural::icosphere(0);
        mesh.corners.set_materials(Some(vec![0; 3 * mesh.face_count()]));
        mesh.corners.library = Some(std::sync::Arc::new(library));
        let mut text = Vec::new();
        super::super::gltf::write::write_gltf(&mut text, &mesh, false, Some(&out)).unwrap();
        let text = String::from_utf8(text).unwrap();
        assert!(text.contains("emissiveTexture") && !text.contains("Ns 96") && !text.contains("extras"), "{text}");
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn missing_materials_keep_their_names() {
        let library = library(&["x".into(), "y".into()], &["absent.mtl".into()], Some(Path::new("/nonexistent")));
        assert_eq!(library.materials.len(), 2);
        assert_eq!(library.material_name(1), "y");
        assert!(library.textures.is_empty());
    }
}
