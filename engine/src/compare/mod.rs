//! Appearance judged as a viewer judges it: two meshes rendered from the same views, with their
//! textures, vertex colours and normals, and the pictures compared pixel by pixel, beside the
//! certified Hausdorff distance between their surfaces.
//!
//! The views are orthographic, spread over the sphere around A's bounding sphere (B is drawn in
//! A's frame, so a B that moved or shrank shows it). Each pixel is the face nearest the viewer,
//! its base colour (material factor × base-colour texture × vertex colour) lit by a headlight on
//! the interpolated normal. The renderer is software and deterministic: the same meshes give the
//! same pictures and figures on every machine and thread count.

mod material;
mod raster;

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::error::MeshError;
use crate::hausdorff::{HausdorffOptions, hausdorff};
use crate::mesh::{Mesh, NONE};
use material::{Palette, Surface};
use raster::{Frame, View, rasterise};

/// How to compare.
#[derive(Debug, Clone, PartialEq)]
pub struct CompareOptions {
    /// Number of views, spread over the sphere.
    pub views: usize,
    /// Width and height of each view's picture, in pixels.
    pub size: usize,
    /// Whether to measure the certified Hausdorff distance too.
    pub hausdorff: bool,
}

impl CompareOptions {
    /// Default number of views.
    pub const DEFAULT_VIEWS: usize = 12;
    /// Default picture size.
    pub const DEFAULT_SIZE: usize = 256;
    /// Most views.
    pub const MAX_VIEWS: usize = 256;
    /// Smallest and largest picture size.
    pub const SIZES: std::ops::RangeInclusive<usize> = 16..=2048;

    /// Checks the options; the error names the one out of range.
    pub fn validate(&self) -> Result<(), MeshError> {
        if !(1..=Self::MAX_VIEWS).contains(&self.views) {
            return Err(MeshError::InvalidParameter {
                name: "views",
                reason: format!("{} views: 1 to {}", self.views, Self::MAX_VIEWS),
            });
        }
        if !Self::SIZES.contains(&self.size) {
            return Err(MeshError::InvalidParameter {
                name: "size",
                reason: format!("{} pixels: {} to {}", self.size, Self::SIZES.start(), Self::SIZES.end()),
            });
        }
        Ok(())
    }
}

impl Default for CompareOptions {
    fn default() -> Self {
        CompareOptions { views: Self::DEFAULT_VIEWS, size: Self::DEFAULT_SIZE, hausdorff: true }
    }
}

/// The figures of a comparison.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CompareReport {
    /// Mean absolute difference over the pixels either picture covers, in 8-bit levels (the
    /// mean of the three channels; an uncovered pixel is black).
    pub mae: f64,
    /// Peak signal-to-noise ratio over the same pixels, dB; `None` when the pictures are the same.
    pub psnr: Option<f64>,
    /// Share of those pixels that only one of the two covers.
    pub silhouette: f64,
    /// Certified symmetric Hausdorff distance (upper bound), paper units of A, when measured (not
    /// for a B without faces).
    pub hausdorff: Option<f64>,
    /// Its lower bound (a distance reached), paper units.
    pub hausdorff_lower: Option<f64>,
    /// The upper bound as % of A's bounding-box diagonal.
    pub hausdorff_diag_pct: Option<f64>,
    /// Faces of A.
    pub faces_a: usize,
    /// Faces of B.
    pub faces_b: usize,
    /// Views rendered.
    pub views: usize,
    /// Pixels per side of each view.
    pub size: usize,
    /// What could not be drawn as the file asks (an image that would not decode).
    pub notes: Vec<String>,
}

/// One view's two pictures (RGB, rows from the top) and which pixels each covers.
#[derive(Debug, Clone)]
struct Pair {
    pictures: [Vec<[u8; 3]>; 2],
    covered: [Vec<bool>; 2],
}

/// A comparison: its figures and the pictures they come from.
#[derive(Debug, Clone)]
pub struct Comparison {
    /// The figures.
    pub report: CompareReport,
    pairs: Vec<Pair>,
    size: usize,
}

/// Renders `a` and `b` from `options.views` views around `a` and compares the pictures.
pub fn compare(a: &Mesh, b: &Mesh, options: &CompareOptions) -> Result<Comparison, MeshError> {
    options.validate()?;
    a.check()?;
    b.check()?;
    let frame = Frame::around(a).ok_or_else(|| MeshError::InvalidParameter {
        name: "a",
        reason: "the first mesh has no faces of any extent to look at".into(),
    })?;
    // A LOD made here shares its input's library: its images are decoded once.
    let first = Palette::of(a.corners.library.as_deref());
    let shared = match (&a.corners.library, &b.corners.library) {
        (Some(x), Some(y)) => std::sync::Arc::ptr_eq(x, y),
        (None, None) => true,
        _ => false,
    };
    let second = if shared { first.clone() } else { Palette::of(b.corners.library.as_deref()) };
    let palettes = [first, second];
    let surfaces = [Surface::of(a), Surface::of(b)];
    let views = View::spread(options.views);
    let pairs: Vec<Pair> = views
        .par_iter()
        .map(|view| {
            let [(pa, ca), (pb, cb)] = [(&surfaces[0], &palettes[0]), (&surfaces[1], &palettes[1])]
                .map(|(surface, palette)| draw(surface, palette, &frame, view, options.size));
            Pair { pictures: [pa, pb], covered: [ca, cb] }
        })
        .collect();
    let (mut sum, mut squares, mut union, mut only_one) = (0.0, 0.0, 0usize, 0usize);
    for pair in &pairs {
        for k in 0..pair.covered[0].len() {
            let (x, y) = (pair.covered[0][k], pair.covered[1][k]);
            if !(x || y) {
                continue;
            }
            union += 1;
            only_one += usize::from(x != y);
            let d = (0..3).map(|c| f64::from(pair.pictures[0][k][c]) - f64::from(pair.pictures[1][k][c]));
            let (abs, sq) = d.fold((0.0, 0.0), |(s, q), d| (s + d.abs(), q + d * d));
            sum += abs / 3.0;
            squares += sq / 3.0;
        }
    }
    let share = |x: f64| if union == 0 { 0.0 } else { x / union as f64 };
    let mse = share(squares);
    // An empty B (a simplifier that threw the model away) is all silhouette, and has no distance.
    let measured = options.hausdorff && b.face_count() > 0;
    let distance = if measured { Some(hausdorff(a, b, &HausdorffOptions::default())?) } else { None };
    let mut notes: Vec<String> = palettes[0].notes.iter().map(|n| format!("A: {n}")).collect();
    if options.hausdorff && !measured {
        notes.push("B has no faces: no distance to measure".into());
    }
    notes.extend(palettes[1].notes.iter().map(|n| format!("B: {n}")));
    let report = CompareReport {
        mae: share(sum),
        psnr: (mse > 0.0).then(|| 10.0 * (255.0 * 255.0 / mse).log10()),
        silhouette: share(only_one as f64),
        hausdorff: distance.as_ref().map(|d| d.hausdorff),
        hausdorff_lower: distance.as_ref().map(|d| d.hausdorff_lower),
        hausdorff_diag_pct: distance.as_ref().map(|d| d.hausdorff_diag_pct),
        faces_a: a.face_count(),
        faces_b: b.face_count(),
        views: views.len(),
        size: options.size,
        notes,
    };
    Ok(Comparison { report, pairs, size: options.size })
}

/// One view of a surface: its picture and which pixels it covers.
fn draw(
    surface: &Surface<'_>,
    palette: &Palette,
    frame: &Frame,
    view: &View,
    size: usize,
) -> (Vec<[u8; 3]>, Vec<bool>) {
    let coverage = rasterise(surface.mesh, frame, view, size);
    let light: DVec3 = view.direction;
    let picture = coverage
        .face
        .iter()
        .zip(&coverage.weights)
        .map(|(&f, &w)| {
            if f == NONE {
                return [0; 3];
            }
            palette.shade(surface, f as usize, w, light).map(|c| (c * 255.0).round() as u8)
        })
        .collect();
    (picture, coverage.face.iter().map(|&f| f != NONE).collect())
}

impl Comparison {
    /// The pictures side by side, a row per view: A, B, and their difference as a heat map
    /// (black where they agree, through red and yellow to white at 64 levels and more).
    pub fn picture(&self) -> image::RgbImage {
        let s = self.size;
        let mut out = image::RgbImage::new(3 * s as u32, (self.pairs.len() * s) as u32);
        for (row, pair) in self.pairs.iter().enumerate() {
            for k in 0..s * s {
                let (x, y) = ((k % s) as u32, (row * s + k / s) as u32);
                let [a, b] = [pair.pictures[0][k], pair.pictures[1][k]];
                let d = (0..3).map(|c| (f64::from(a[c]) - f64::from(b[c])).abs()).sum::<f64>() / 3.0;
                out.put_pixel(x, y, image::Rgb(a));
                out.put_pixel(x + s as u32, y, image::Rgb(b));
                out.put_pixel(x + 2 * s as u32, y, image::Rgb(heat(d / 64.0)));
            }
        }
        out
    }

    /// Writes [`Comparison::picture`] as a PNG file.
    pub fn write_png(&self, path: &std::path::Path) -> Result<(), MeshError> {
        self.picture()
            .save_with_format(path, image::ImageFormat::Png)
            .map_err(|e| MeshError::Io { path: path.to_path_buf(), message: e.to_string() })
    }
}

/// A heat colour for `t` in [0, 1]: black, red, yellow, white.
fn heat(t: f64) -> [u8; 3] {
    let t = t.clamp(0.0, 1.0) * 3.0;
    let channel = |from: f64| ((t - from).clamp(0.0, 1.0) * 255.0).round() as u8;
    [channel(0.0), channel(1.0), channel(2.0)]
}
