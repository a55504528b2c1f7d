//! The integer grids of the compact `.pm` form: positions, texture coordinates and colours on
//! ranges split into `2^bits − 1` steps, normals as octahedral coordinates.

use super::header::Reader;
use crate::error::MeshError;
use crate::pm::ProgressiveMesh;

/// How finely the compact form keeps values: bits per position coordinate (over the largest side
/// of the bounding box), per octahedral normal coordinate, per texture coordinate (over the
/// texture coordinates' range) and per colour channel (over each channel's range).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Precision {
    /// Bits per position coordinate.
    pub position_bits: u8,
    /// Bits per octahedral normal coordinate.
    pub normal_bits: u8,
    /// Bits per texture coordinate.
    pub uv_bits: u8,
    /// Bits per colour channel.
    pub color_bits: u8,
}

impl Default for Precision {
    /// 16-bit positions and texture coordinates (a 64th of a texel of a 4096² texture), 12-bit
    /// octahedral normals (within 0.05°) and 12-bit colours.
    fn default() -> Self {
        Precision { position_bits: 16, normal_bits: 12, uv_bits: 16, color_bits: 12 }
    }
}

/// Most bits a grid may have: a grid value must stay exact in an `f32`'s 24-bit significand.
pub(super) const MAX_BITS: u8 = 24;

/// An integer grid over `N` coordinates: value `q` stands for `min + q · step`, `q` in
/// `0..2^bits`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid<const N: usize> {
    /// Bits per coordinate (1 to 24).
    pub bits: u8,
    /// The value of grid point 0, per coordinate.
    pub min: [f32; N],
    /// The distance between grid points, per coordinate.
    pub step: [f32; N],
}

impl<const N: usize> Grid<N> {
    /// The grid with `bits` over the range of `values`; `uniform` gives every coordinate the step
    /// of the widest (so that positions keep their shape).
    fn fit<'a>(values: impl Iterator<Item = &'a [f32; N]>, bits: u8, uniform: bool) -> Grid<N> {
        let mut lo = [f32::INFINITY; N];
        let mut hi = [f32::NEG_INFINITY; N];
        for v in values {
            for a in 0..N {
                lo[a] = lo[a].min(v[a]);
                hi[a] = hi[a].max(v[a]);
            }
        }
        let levels = ((1u64 << bits) - 1) as f64;
        let mut step = [0f32; N];
        for a in 0..N {
            if lo[a] > hi[a] {
                (lo[a], hi[a]) = (0.0, 0.0);
            }
            step[a] = ((hi[a] as f64 - lo[a] as f64) / levels) as f32;
        }
        if uniform {
            let widest = step.iter().copied().fold(0f32, f32::max);
            step = [widest; N];
        }
        // A flat coordinate still needs a step the reader can divide by; and rounding the step
        // down to an f32 must not push the top of the range off the grid.
        for a in 0..N {
            if !step[a].is_normal() || step[a] < 0.0 {
                step[a] = 1.0;
            }
            while (hi[a] as f64 - lo[a] as f64) / step[a] as f64 > levels {
                step[a] = f32::from_bits(step[a].to_bits() + 1);
            }
        }
        Grid { bits, min: lo, step }
    }

    pub(super) fn quantize(&self, v: &[f32; N]) -> [i64; N] {
        let top = ((1u64 << self.bits) - 1) as f64;
        std::array::from_fn(|a| {
            ((v[a] as f64 - self.min[a] as f64) / self.step[a] as f64).round().clamp(0.0, top) as i64
        })
    }

    pub(super) fn value(&self, q: &[i64]) -> [f32; N] {
        std::array::from_fn(|a| (self.min[a] as f64 + q[a] as f64 * self.step[a] as f64) as f32)
    }

    pub(super) fn write(&self, out: &mut Vec<u8>, uniform: bool) {
        out.push(self.bits);
        for m in self.min {
            out.extend_from_slice(&m.to_le_bytes());
        }
        for s in if uniform { &self.step[..1] } else { &self.step[..] } {
            out.extend_from_slice(&s.to_le_bytes());
        }
    }

    pub(super) fn read(r: &mut Reader, uniform: bool, what: &str) -> Result<Grid<N>, MeshError> {
        let bits = r.take(1)?[0];
        if bits == 0 || bits > MAX_BITS {
            return Err(r.error(format!("{what} grid of {bits} bits (1 to {MAX_BITS})")));
        }
        let mut min = [0f32; N];
        for m in &mut min {
            *m = r.f32()?;
        }
        let mut step = [0f32; N];
        for s in step.iter_mut().take(if uniform { 1 } else { N }) {
            *s = r.f32()?;
            if s.is_nan() || *s <= 0.0 {
                return Err(r.error(format!("{what} grid step {s} is not positive")));
            }
        }
        if uniform {
            step = [step[0]; N];
        }
        Ok(Grid { bits, min, step })
    }
}

/// The grids of a compact file: the positions', and those of the attributes present.
#[derive(Debug, Clone, PartialEq)]
pub struct Quantization {
    /// The positions' grid (the same step on every axis).
    pub positions: Grid<3>,
    /// Bits per octahedral coordinate of a normal.
    pub normal_bits: u8,
    /// The texture coordinates' grid, when there are any.
    pub uvs: Option<Grid<2>>,
    /// The second texture coordinates' grid, when there are any.
    pub uvs1: Option<Grid<2>>,
    /// The colours' grid, when there are any.
    pub colors: Option<Grid<4>>,
}

impl Quantization {
    /// The grids that hold every position and value of `pm` at `precision`.
    pub fn fit(pm: &ProgressiveMesh, precision: &Precision) -> Quantization {
        let clamp = |bits: u8| bits.clamp(1, MAX_BITS);
        let positions =
            pm.base().positions.iter().chain(pm.splits().iter().flat_map(|s| [&s.new_position, &s.split_position]));
        let values = pm.attributes().map(|a| &a.values);
        Quantization {
            positions: Grid::fit(positions, clamp(precision.position_bits), true),
            normal_bits: clamp(precision.normal_bits),
            uvs: values.and_then(|v| v.uvs()).map(|u| Grid::fit(u.iter(), clamp(precision.uv_bits), false)),
            uvs1: values.and_then(|v| v.uvs1()).map(|u| Grid::fit(u.iter(), clamp(precision.uv_bits), false)),
            colors: values.and_then(|v| v.colors()).map(|c| Grid::fit(c.iter(), clamp(precision.color_bits), false)),
        }
    }
}

/// A unit normal as two octahedral coordinates on a `bits` grid (Meyer et al. 2010).
pub(super) fn octahedral(n: [f32; 3], bits: u8) -> [i64; 2] {
    let [x, y, z] = n.map(|c| c as f64);
    let l1 = x.abs() + y.abs() + z.abs();
    let (mut u, mut v) = if l1 > 1e-30 && l1.is_finite() { (x / l1, y / l1) } else { (0.0, 0.0) };
    if z < 0.0 && l1 > 1e-30 {
        (u, v) = ((1.0 - v.abs()) * u.signum(), (1.0 - u.abs()) * v.signum());
    }
    let top = ((1u64 << bits) - 1) as f64;
    [u, v].map(|c| ((c + 1.0) * 0.5 * top).round().clamp(0.0, top) as i64)
}

/// The unit normal at octahedral grid point `q`.
pub(super) fn from_octahedral(q: &[i64], bits: u8) -> [f32; 3] {
    let top = ((1u64 << bits) - 1) as f64;
    let u = q[0] as f64 / top * 2.0 - 1.0;
    let v = q[1] as f64 / top * 2.0 - 1.0;
    let z = 1.0 - u.abs() - v.abs();
    let (x, y) = if z < 0.0 { ((1.0 - v.abs()) * u.signum(), (1.0 - u.abs()) * v.signum()) } else { (u, v) };
    let l = (x * x + y * y + z * z).sqrt();
    [(x / l) as f32, (y / l) as f32, (z / l) as f32]
}
