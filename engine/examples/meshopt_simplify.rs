//! meshoptimizer's `simplify` (the benches' peer, 0.7, positions only, no error limit) on one mesh,
//! written to a file, for comparisons outside Rust (`tools/meshlab_compare.py`).
//!
//! `cargo run --release -p meshlod-engine --example meshopt_simplify -- IN OUT TARGET_FACES`
//!
//! Prints the face count reached (meshoptimizer may stop above the target).

#[path = "../benches/support/peer.rs"]
mod peer;

use meshlod_engine::io::{read_mesh, write_mesh};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [input, output, target] = args.as_slice() else {
        return Err("usage: meshopt_simplify IN OUT TARGET_FACES".into());
    };
    let out = peer::meshopt_simplify(&read_mesh(input)?, target.parse()?);
    write_mesh(output, &out)?;
    println!("{}", out.face_count());
    Ok(())
}
