//! meshoptimizer's `simplify` (the benches' peer, 0.7, positions only, no error limit) on one mesh,
//! written to a file, for comparisons outside Rust (`tools/meshlab_compare.py`).
//!
//! `cargo run --release -p meshlod-engine --example meshopt_simplify -- IN OUT TARGET_FACES`
//!
//! Prints the face count reached (meshoptimizer may stop above the target).

use meshlod_engine::Mesh;
use meshlod_engine::io::{read_mesh, write_mesh};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [input, output, target] = args.as_slice() else {
        return Err("usage: meshopt_simplify IN OUT TARGET_FACES".into());
    };
    let target: usize = target.parse()?;
    let mesh = read_mesh(input)?;
    let bytes: Vec<u8> = mesh.positions.iter().flat_map(|p| p.iter().flat_map(|c| c.to_le_bytes())).collect();
    let adapter = meshopt::VertexDataAdapter::new(&bytes, 12, 0)?;
    let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    let kept = meshopt::simplify(&indices, &adapter, target * 3, f32::MAX, meshopt::SimplifyOptions::None, None);
    // Only the vertices the result uses, in first-use order.
    let mut remap = vec![u32::MAX; mesh.vertex_count()];
    let mut positions = Vec::new();
    let triangles = kept
        .chunks_exact(3)
        .map(|t| {
            [0, 1, 2].map(|i| {
                let v = t[i] as usize;
                if remap[v] == u32::MAX {
                    remap[v] = positions.len() as u32;
                    positions.push(mesh.positions[v]);
                }
                remap[v]
            })
        })
        .collect();
    let out = Mesh::new(positions, triangles)?;
    write_mesh(output, &out)?;
    println!("{}", out.face_count());
    Ok(())
}
