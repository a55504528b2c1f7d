//! Output digests of the simplifier and the refiner on fixed cases, compared with the recorded
//! ones in `tests/golden/digests.tsv`: a change that moves any output bit (a refactor that should
//! not, a reordered float operation) fails here with the cases it moved.
//!
//! When a change is meant to move outputs, rerun with `MESHLOD_BLESS=1` to rewrite the file, and
//! say why in the commit (the regenerated reports show by how much).

use std::collections::BTreeMap;
use std::path::PathBuf;

use meshlod_engine::io::read_mesh;
use meshlod_engine::pm_format::encode_lossless;
use meshlod_engine::refine::{RefineMode, RefineOptions, refine};
use meshlod_engine::simplify::{BoundaryMode, Metric, NormalUpdate, Placement, SimplifyOptions, simplify};
use meshlod_engine::{Mesh, procedural};

/// FNV-1a, 64 bits: enough to tell outputs apart, and the same on every platform.
struct Fnv(u64);

impl Fnv {
    fn new() -> Fnv {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
    fn bytes(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    fn mesh(&mut self, mesh: &Mesh) {
        self.bytes(&(mesh.positions.len() as u64).to_le_bytes());
        for p in &mesh.positions {
            p.iter().for_each(|c| self.bytes(&c.to_bits().to_le_bytes()));
        }
        self.bytes(&(mesh.triangles.len() as u64).to_le_bytes());
        for t in &mesh.triangles {
            t.iter().for_each(|v| self.bytes(&v.to_le_bytes()));
        }
    }
}

fn golden_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/golden/digests.tsv")
}

fn simplify_digest(mesh: &Mesh, options: &SimplifyOptions) -> String {
    let out = simplify(mesh, &SimplifyOptions { record_progressive: true, ..options.clone() }).unwrap();
    let mut h = Fnv::new();
    h.mesh(&out.mesh);
    h.bytes(&encode_lossless(out.progressive.as_ref().unwrap()));
    let s = &out.stats;
    format!("{:016x}\tfaces={} collapses={} rejected={}", h.0, s.faces_out, s.collapses, s.rejected)
}

fn refine_digest(mesh: &Mesh, options: &RefineOptions) -> String {
    let out = refine(mesh, options).unwrap();
    let mut h = Fnv::new();
    h.mesh(&out.mesh);
    format!("{:016x}\tfaces={} collapses={}", h.0, out.stats.faces_out, out.stats.collapses)
}

/// Every case: name → digest line.
fn cases() -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    let ratio = |r: f64| SimplifyOptions { target_ratio: Some(r), ..Default::default() };
    let variants: Vec<(&str, SimplifyOptions)> = vec![
        ("qem", ratio(0.9)),
        ("w1", SimplifyOptions { metric: Metric::Qfvp { w: 1.0 }, ..ratio(0.9) }),
        (
            "w1.5-recompute",
            SimplifyOptions { metric: Metric::Qfvp { w: 1.5 }, normals: NormalUpdate::Recompute, ..ratio(0.95) },
        ),
        ("melax", SimplifyOptions { metric: Metric::Melax, ..ratio(0.9) }),
        ("paper-lock", SimplifyOptions { placement: Placement::Paper, boundary: BoundaryMode::Lock, ..ratio(0.9) }),
        ("endpoint", SimplifyOptions { placement: Placement::Endpoint, ..ratio(0.99) }),
        ("guard", SimplifyOptions { guard: 1.0, ..ratio(0.95) }),
        ("angle30", SimplifyOptions { max_normal_change_degrees: 30.0, ..ratio(0.99) }),
    ];
    let procedural = [
        ("sphere", procedural::icosphere(4)),
        ("torus", procedural::torus(48, 16, 0.3)),
        ("box", procedural::sharp_box(8)),
        ("terrain", procedural::terrain(32, 5)),
        ("blob", procedural::bumpy_blob(30, 50, 2)),
    ];
    for (name, mesh) in &procedural {
        for (variant, options) in &variants {
            out.insert(format!("simplify/{name}/{variant}"), simplify_digest(mesh, options));
        }
        for (mode, etc) in [(RefineMode::Simplify, 1.0), (RefineMode::Subdivide, 1.5), (RefineMode::Both, 1.0)] {
            let options = RefineOptions { etc: Some(etc), mode, ..Default::default() };
            out.insert(format!("refine/{name}/{mode:?}-{etc}"), refine_digest(mesh, &options));
        }
    }
    if let Some(dir) = meshlod_engine::datasets::require_shared_meshes("digest") {
        for name in ["stanford-bunny", "cow", "fandisk", "beetle", "nefertiti"] {
            let mesh = read_mesh(dir.join(format!("{name}.obj"))).unwrap();
            for (variant, options) in [
                ("qem-90", ratio(0.9)),
                ("qem-99", ratio(0.99)),
                ("w1-99", SimplifyOptions { metric: Metric::Qfvp { w: 1.0 }, ..ratio(0.99) }),
                ("guard-99", SimplifyOptions { guard: 1.0, ..ratio(0.99) }),
            ] {
                out.insert(format!("simplify/{name}/{variant}"), simplify_digest(&mesh, &options));
            }
            let options = RefineOptions { etc: Some(1.0), mode: RefineMode::Both, ..Default::default() };
            out.insert(format!("refine/{name}/Both-1"), refine_digest(&mesh, &options));
        }
    }
    out
}

#[test]
fn outputs_match_the_recorded_digests() {
    let got = cases();
    let path = golden_path();
    if std::env::var_os("MESHLOD_BLESS").is_some() {
        let text: String = got.iter().map(|(k, v)| format!("{k}\t{v}\n")).collect();
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(&path, text).unwrap();
        eprintln!("digest: wrote {} cases to {}", got.len(), path.display());
        return;
    }
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let recorded: BTreeMap<&str, &str> = text.lines().filter_map(|l| l.split_once('\t')).collect();
    let mut moved = Vec::new();
    for (case, digest) in &got {
        match recorded.get(case.as_str()) {
            Some(&r) if r == digest => {}
            Some(&r) => moved.push(format!("{case}: recorded {r}, now {digest}")),
            None => moved.push(format!("{case}: not recorded (rerun with MESHLOD_BLESS=1)")),
        }
    }
    assert!(moved.is_empty(), "{} of {} outputs moved:\n{}", moved.len(), got.len(), moved.join("\n"));
    // Shared-mesh cases are only computed where the meshes are (and CI fails without them).
    assert!(got.len() >= 5 * 11, "too few cases computed: {}", got.len());
}

/// The simplifier's setup runs on the rayon pool (the fans, the classes, the first ranking of the
/// edges, the outputs): its output must not depend on how many threads the pool has. Meshes large
/// enough for several blocks of every parallel pass, with borders (terrain), holes that close, and
/// planar faces whose collapses tie (the box: there the order of the queue's entries decides).
#[test]
fn outputs_do_not_depend_on_the_thread_count() {
    let blob = procedural::bumpy_blob(160, 240, 7);
    let meshes = [
        ("blob", blob.clone()),
        ("holed blob", procedural::with_triangular_holes(&blob, 40)),
        ("terrain", procedural::terrain(160, 3)),
        ("box", procedural::sharp_box(80)),
    ];
    let options = SimplifyOptions { target_ratio: Some(0.95), ..Default::default() };
    for (name, mesh) in &meshes {
        assert!(mesh.vertex_count() > 3 * 8192, "{name}: {} vertices", mesh.vertex_count());
        let digests: Vec<String> = [1, 2, 3]
            .map(|threads| {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                pool.install(|| simplify_digest(mesh, &options))
            })
            .into();
        assert!(digests.iter().all(|d| *d == digests[0]), "{name}: {digests:?}");
    }
}
