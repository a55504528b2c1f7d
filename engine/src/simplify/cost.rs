//! The collapse cost of an edge: QFVP's normal factor, Melax's curvature term, and the candidate
//! the metric prefers ([`State::evaluate`]), its placement chosen in `placement.rs`.

use super::candidate::Candidate;
use super::kernel::State;
use super::placement::{Choice, Keep};
use super::vertex::{VertexData, to_f32};

impl State<'_> {
    /// The collapse of edge {a, b} the metric prefers, or `None` if the rules forbid every
    /// direction and placement. Geometry-independent rules only; the rest is in `is_legal`.
    pub(crate) fn evaluate(&self, a: u32, b: u32) -> Option<Candidate> {
        Some(self.candidate(a, b, self.choose(a, b)?))
    }

    /// The collapse of edge {a, b} that `choice` ([`State::choose`]'s answer for it) describes.
    pub(super) fn candidate(&self, a: u32, b: u32, choice: Choice) -> Candidate {
        let survivor = self.survivor(choice.keep, a, b);
        let removed = survivor ^ a ^ b;
        Candidate { cost: choice.cost, survivor, removed, position: to_f32(choice.position) }
    }

    /// The endpoint of edge {a, b} that `keep` names. The survivor of a moving collapse is the
    /// endpoint that already has more faces, so fewer faces change corners (smaller vertex split).
    #[inline]
    pub(super) fn survivor(&self, keep: Keep, a: u32, b: u32) -> u32 {
        match keep {
            Keep::A => a,
            Keep::B => b,
            Keep::Larger if self.topo.fans[a as usize].len() >= self.topo.fans[b as usize].len() => a,
            Keep::Larger => b,
        }
    }

    /// A quadric cost as the queue ranks it: over `area`, the area behind the merged quadric, where
    /// the run has a distance term ([`State::per_area`]), so that the key is a mean squared
    /// distance (to the quadric's planes, plus the term's measured one) and a small part of the
    /// surface is not cheap to move for being small: the error measured (the Hausdorff distance)
    /// is a largest distance, whatever the area behind it (docs/benchmarks.md). The cost as it is
    /// otherwise: the paper's.
    #[inline]
    pub(super) fn ranked_cost(&self, cost: f64, area: f64) -> f64 {
        if self.terms.per_area && area > 0.0 { cost / area } else { cost }
    }

    /// QFVP's normal term `(1 − cos θ)^w` of an edge with these endpoints (1 for QEM and w = 0).
    #[inline]
    pub(super) fn normal_factor(&self, va: &VertexData, vb: &VertexData) -> f64 {
        let w = self.config.options.metric.w().unwrap_or(0.0);
        if w == 0.0 {
            return 1.0;
        }
        let x = 1.0 - va.normal.dot(vb.normal).clamp(-1.0, 1.0);
        match w {
            0.5 => x.sqrt(),
            1.0 => x,
            1.5 => x * x.sqrt(),
            2.0 => x * x,
            _ => x.powf(w),
        }
    }

    /// Melax's cost of moving `u` onto `v`: |u − v| × max over faces f at u of
    /// min over faces n on edge uv of (1 − f·n) / 2.
    pub(super) fn melax_cost(&self, u: u32, v: u32) -> f64 {
        let length = (self.point(u) - self.point(v)).length();
        let (shared, count) = self.edge_corners(u, v);
        let shared = &shared[..count.min(2)];
        let mut curvature: f64 = 0.0;
        for c in &self.topo.fans[u as usize] {
            let nf = self.face_normal(c.face);
            let min = shared.iter().map(|s| (1.0 - nf.dot(self.face_normal(s.face))) / 2.0).fold(1.0f64, f64::min);
            curvature = curvature.max(min);
        }
        length * curvature
    }
}
