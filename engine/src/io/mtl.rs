//! Wavefront MTL material files, translated into glTF terms ([`MaterialLibrary`]) so that an OBJ
//! written as glTF draws with its diffuse colour, opacity and diffuse texture, and written back
//! from them beside an OBJ ([`write_library`]) so that an OBJ written from any input draws with its
//! materials.
//!
//! Only what a textured LOD needs is read: `newmtl`, `Kd`, `d` and `map_Kd` (its options skipped,
//! the file name may hold spaces). `Tr` is not read: exporters disagree on whether it means
//! transparency or opacity. A material named by `usemtl` but found in no MTL file keeps its name.
//! The same four statements are written.

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
                let small = std::fs::metadata(&file).is_ok_and(|m| m.is_file() && m.len() <= MAX_MTL_BYTES);
                if let Some(text) = small.then(|| std::fs::read(&file).ok()).flatten() {
                    entries.extend(parse(&String::from_utf8_lossy(&text)));
                }
            }
        }
    }
    let mut library = MaterialLibrary::default();
    let mut texture_files: Vec<String> = Vec::new();
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
            let index = texture_files.iter().position(|f| f == file).unwrap_or_else(|| {
                texture_files.push(file.clone());
                texture_files.len() - 1
            });
            pbr["baseColorTexture"] = json!({ "index": index });
        }
        let mut material = json!({ "name": entry.name, "pbrMetallicRoughness": pbr });
        if opacity < 1.0 {
            material["alphaMode"] = json!("BLEND");
        }
        library.materials.push(material);
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
/// it), `Kd` and `d` from its base colour, and `map_Kd` for its base-colour texture. Each such image
/// is put beside the file so that the OBJ draws without the input's folder: an image file already
/// in that folder is named as it is; one elsewhere, or one held in memory (from a GLB or a data
/// URI), is written there under its own name (`STEM_NAME` where a different file has that name,
/// `STEM` the MTL file's stem); one that cannot be read is named by its path relative to the
/// folder, as the input had it.
pub(crate) fn write_library(path: &Path, library: &MaterialLibrary) -> std::io::Result<()> {
    let folder = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let stem = path.file_stem().map_or("materials".into(), |s| s.to_string_lossy().into_owned());
    let mut placed: Vec<Option<String>> = vec![None; library.images.len()];
    let mut written: Vec<String> = Vec::new();
    let mut text = String::from("# meshlod\n");
    for (index, material) in library.materials.iter().enumerate() {
        // (Writing to a String cannot fail.)
        let _ = writeln!(text, "\nnewmtl {}", one_line(&library.material_name(index as u32)));
        let pbr = &material["pbrMetallicRoughness"];
        let factor = |k: usize| pbr["baseColorFactor"][k].as_f64().filter(|x| x.is_finite()).unwrap_or(1.0);
        let _ = writeln!(text, "Kd {} {} {}", factor(0), factor(1), factor(2));
        if factor(3) < 1.0 {
            let _ = writeln!(text, "d {}", factor(3));
        }
        let image = pbr["baseColorTexture"]["index"]
            .as_u64()
            .and_then(|t| library.textures.get(t as usize))
            .and_then(|t| t["source"].as_u64())
            .map(|i| i as usize)
            .filter(|&i| i < library.images.len());
        if let Some(i) = image {
            if placed[i].is_none() {
                placed[i] = Some(place_image(folder, &stem, i, &library.images[i], &mut written)?);
            }
            if let Some(name) = &placed[i] {
                let _ = writeln!(text, "map_Kd {name}");
            }
        }
    }
    std::fs::write(path, text)
}

/// The files an OBJ file refers to, as [`super::write_mesh`] writes them: the MTL files its
/// `mtllib` statements name (before its first vertex) and the textures their `map_Kd` statements
/// name, all in the OBJ's folder. Empty for an OBJ without materials or a file that cannot be read.
pub(crate) fn referenced_files(obj: &Path) -> Vec<PathBuf> {
    use std::io::BufRead as _;
    let folder = obj.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
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
        let small = std::fs::metadata(mtl).is_ok_and(|m| m.is_file() && m.len() <= MAX_MTL_BYTES);
        if let Some(text) = small.then(|| std::fs::read(mtl).ok()).flatten() {
            let folder = mtl.parent().unwrap_or(folder);
            textures.extend(parse(&String::from_utf8_lossy(&text)).into_iter().filter_map(|e| Some(folder.join(e.texture?))));
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
            match super::read_referenced(file) {
                Ok(bytes) => (bytes, name),
                Err(_) => {
                    let relative = super::gltf_write::relative_path(file, folder);
                    return Ok(one_line(&relative.unwrap_or_else(|| file.to_string_lossy().into_owned())));
                }
            }
        }
        ImageSource::Bytes(bytes) => {
            let extension = match super::gltf_write::sniff_image(bytes).or(image.mime_type.as_deref()) {
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
            Ok(meta) if meta.is_file() && super::read_referenced(&target).is_ok_and(|held| held == bytes) => {
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

/// The `newmtl` entries of an MTL file.
fn parse(text: &str) -> Vec<Entry> {
    let mut entries: Vec<Entry> = Vec::new();
    for line in text.lines() {
        let line = line.trim();
        let mut tokens = line.split_ascii_whitespace();
        let Some(keyword) = tokens.next() else { continue };
        let rest = line[keyword.len()..].trim();
        if keyword == "newmtl" {
            entries.push(Entry { name: rest.to_string(), ..Default::default() });
            continue;
        }
        let Some(entry) = entries.last_mut() else { continue };
        let numbers: Vec<f64> = tokens.map_while(|t| t.parse::<f64>().ok()).filter(|x| x.is_finite()).collect();
        match keyword {
            "Kd" if numbers.len() >= 3 => entry.diffuse = Some([numbers[0], numbers[1], numbers[2]]),
            "d" if !numbers.is_empty() => entry.opacity = Some(numbers[0]),
            "map_Kd" => entry.texture = texture_file(rest),
            _ => {}
        }
    }
    entries
}

/// The file name of a `map_*` statement: its options (`-o 0 0 0`, `-clamp on`, ...) skipped.
fn texture_file(rest: &str) -> Option<String> {
    let tokens: Vec<&str> = rest.split_ascii_whitespace().collect();
    let mut i = 0;
    while i < tokens.len() && tokens[i].starts_with('-') {
        i += 1;
        // The option's arguments: numbers, or on/off, or one word for -imfchan / -type.
        let words = matches!(tokens[i - 1], "-imfchan" | "-type" | "-bm");
        while i < tokens.len()
            && (tokens[i].parse::<f64>().is_ok()
                || matches!(tokens[i], "on" | "off")
                || (words && !tokens[i].contains('.')))
        {
            i += 1;
        }
    }
    let name = tokens[i..].join(" ");
    (!name.is_empty()).then_some(name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_keep_colour_opacity_and_texture() {
        let entries = parse("newmtl a b\nKd 0.5 0.25 1\nd 0.5\nnewmtl tex\nmap_Kd -o 0.1 0.2 -clamp on my tex.png\n");
        assert_eq!(entries.len(), 2);
        assert_eq!(entries[0].name, "a b");
        assert_eq!(entries[0].diffuse, Some([0.5, 0.25, 1.0]));
        assert_eq!(entries[0].opacity, Some(0.5));
        assert_eq!(entries[1].texture.as_deref(), Some("my tex.png"));
    }

    #[test]
    fn missing_materials_keep_their_names() {
        let library = library(&["x".into(), "y".into()], &["absent.mtl".into()], Some(Path::new("/nonexistent")));
        assert_eq!(library.materials.len(), 2);
        assert_eq!(library.material_name(1), "y");
        assert!(library.textures.is_empty());
    }
}
