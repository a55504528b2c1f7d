//! Subcommands of the `meshlod` binary.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand, ValueEnum};
use meshlod_engine::hausdorff::{HausdorffOptions, hausdorff};
use meshlod_engine::io::{read_mesh, write_mesh};
use meshlod_engine::validate::{clean, validate};
use meshlod_engine::{Mesh, procedural};
use serde_json::json;

/// meshlod: progressive meshes and levels of detail for heavy triangle meshes.
#[derive(Debug, Parser)]
#[command(name = "meshlod", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Print a validation report: counts, bounding box, degenerate/duplicate faces, manifoldness.
    Info {
        /// Mesh file (.obj or .ply).
        file: PathBuf,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Convert between OBJ and PLY (format from the output extension).
    Convert {
        /// Input mesh.
        input: PathBuf,
        /// Output mesh (.obj or binary .ply).
        output: PathBuf,
        /// Weld coincident vertices, drop degenerate/duplicate faces and unreferenced vertices.
        #[arg(long)]
        clean: bool,
    },
    /// Symmetric Metro-style Hausdorff distance between two meshes (units relative to A).
    Hausdorff {
        /// Reference mesh A (its bounding box defines the units).
        a: PathBuf,
        /// Mesh B.
        b: PathBuf,
        /// Edge and face samples per direction (default: the larger vertex count, at least 10000).
        #[arg(long)]
        samples: Option<usize>,
        /// Seed of the face sampler.
        #[arg(long, default_value_t = HausdorffOptions::default().seed)]
        seed: u64,
        /// Do not sample vertices.
        #[arg(long)]
        no_vertex_samples: bool,
        /// Do not sample edges.
        #[arg(long)]
        no_edge_samples: bool,
        /// Do not sample faces.
        #[arg(long)]
        no_face_samples: bool,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Write a procedurally generated mesh (for trying meshlod without data).
    Generate {
        /// Which shape.
        #[arg(value_enum)]
        shape: Shape,
        /// Output mesh (.obj or .ply).
        #[arg(short, long)]
        output: PathBuf,
        /// Resolution: subdivision level for the sphere, grid steps for the others.
        #[arg(long, default_value_t = 64)]
        resolution: u32,
    },
    /// Run the main job on a built-in mesh: generate, validate, measure. Needs no files.
    Demo {
        /// Directory to write the demo meshes into (default: a temporary directory).
        #[arg(long)]
        out_dir: Option<PathBuf>,
    },
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum Shape {
    Sphere,
    Torus,
    Box,
    Terrain,
    Blob,
}

fn generate(shape: Shape, resolution: u32) -> Mesh {
    match shape {
        Shape::Sphere => procedural::icosphere(resolution.min(9)),
        Shape::Torus => procedural::torus(resolution * 2, resolution, 0.35),
        Shape::Box => procedural::sharp_box(resolution),
        Shape::Terrain => procedural::terrain(resolution, 1),
        Shape::Blob => procedural::bumpy_blob(resolution, resolution * 2, 1),
    }
}

fn load(path: &Path) -> Result<Mesh> {
    Ok(read_mesh(path)?)
}

/// Runs one parsed command line.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Info { file, json } => {
            let mesh = load(&file)?;
            let report = validate(&mesh);
            if json {
                println!("{}", serde_json::to_string_pretty(&report)?);
            } else {
                println!("{}", file.display());
                let value = serde_json::to_value(&report)?;
                for (key, v) in value.as_object().expect("report is an object") {
                    println!("  {key:<30} {v}");
                }
            }
        }
        Command::Convert { input, output, clean: do_clean } => {
            let mut mesh = load(&input)?;
            if do_clean {
                let (cleaned, report) = clean(&mesh);
                eprintln!("clean: {}", serde_json::to_string(&report)?);
                mesh = cleaned;
            }
            write_mesh(&output, &mesh)?;
        }
        Command::Hausdorff { a, b, samples, seed, no_vertex_samples, no_edge_samples, no_face_samples, json } => {
            if samples == Some(0) {
                bail!("--samples must be at least 1");
            }
            let (mesh_a, mesh_b) = (load(&a)?, load(&b)?);
            let started = Instant::now();
            let options = HausdorffOptions {
                samples,
                seed,
                sample_vertices: !no_vertex_samples,
                sample_edges: !no_edge_samples,
                sample_faces: !no_face_samples,
            };
            let report = hausdorff(&mesh_a, &mesh_b, &options)?;
            let seconds = started.elapsed().as_secs_f64();
            if json {
                let mut value = serde_json::to_value(report)?;
                value["seconds"] = json!(seconds);
                println!("{}", serde_json::to_string_pretty(&value)?);
            } else {
                println!(
                    "hausdorff {:.6} paper units ({:.4}% of diagonal), mean {:.6}, rms {:.6}, {} samples, {:.3} s",
                    report.hausdorff, report.hausdorff_diag_pct, report.mean, report.rms, report.samples, seconds
                );
            }
        }
        Command::Generate { shape, output, resolution } => {
            if resolution == 0 {
                bail!("--resolution must be at least 1");
            }
            write_mesh(&output, &generate(shape, resolution))?;
        }
        Command::Demo { out_dir } => demo(out_dir)?,
    }
    Ok(())
}

fn demo(out_dir: Option<PathBuf>) -> Result<()> {
    let dir = match out_dir {
        Some(d) => d,
        None => std::env::temp_dir().join(format!("meshlod-demo-{}", std::process::id())),
    };
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let original = procedural::bumpy_blob(120, 240, 7);
    let original_path = dir.join("blob.ply");
    write_mesh(&original_path, &original)?;
    let report = validate(&original);
    println!(
        "demo mesh: {} vertices, {} faces, manifold and oriented: {}, written to {}",
        report.vertices,
        report.faces,
        report.is_manifold_oriented,
        original_path.display()
    );
    let coarse = procedural::bumpy_blob(30, 60, 7);
    let coarse_path = dir.join("blob-coarse.ply");
    write_mesh(&coarse_path, &coarse)?;
    let started = Instant::now();
    let distance = hausdorff(&original, &coarse, &HausdorffOptions::default())?;
    println!(
        "coarse version: {} faces, Hausdorff {:.5} paper units ({:.3}% of diagonal), mean {:.5}, measured in {:.3} s",
        coarse.face_count(),
        distance.hausdorff,
        distance.hausdorff_diag_pct,
        distance.mean,
        started.elapsed().as_secs_f64()
    );
    Ok(())
}
