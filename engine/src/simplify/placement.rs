//! Where the merged vertex goes and which endpoint survives: the quadric minimiser, the paper's
//! rule (endpoints and midpoint), the endpoint-only rule, and the boundary rules, each ranked by
//! the metric's cost.

use glam::DVec3;

use super::kernel::State;
use super::options::{BoundaryMode, Metric, Placement};
use super::vertex::{VertexData, VertexKind, to_f64};

/// Which endpoint of an edge survives its collapse.
#[derive(Debug, Clone, Copy)]
pub(super) enum Keep {
    A,
    B,
    /// Either may: the one with more faces ([`State::evaluate`]).
    Larger,
}

/// A collapse as [`State::choose`] ranks it, before the survivor is fixed.
#[derive(Debug, Clone, Copy)]
pub(super) struct Choice {
    pub(super) cost: f64,
    pub(super) error: f64,
    pub(super) keep: Keep,
    pub(super) position: DVec3,
}

impl State<'_> {
    /// The metric's preferred collapse of edge {a, b} as cost, error and position, the survivor
    /// left open where either endpoint may move: the queue key needs no more, so queueing an edge
    /// never reads the fans.
    #[inline]
    pub(super) fn choose(&self, a: u32, b: u32) -> Option<Choice> {
        let (va, vb) = (&self.vertices[a as usize], &self.vertices[b as usize]);
        let (ka, kb) = (va.kind, vb.kind);
        let (may_keep_a, may_keep_b, may_move) = self.allowed(a, b, ka, kb)?;
        let (pa, pb) = (to_f64(va.position), to_f64(vb.position));
        let quadric_cost = matches!(self.config.options.metric, Metric::Qem | Metric::Qfvp { .. });
        if quadric_cost
            && self.terms.wedges.is_none()
            && !(may_move && self.config.options.placement != Placement::Endpoint)
        {
            return self.endpoints_only(va, vb, (pa, pb), may_keep_a, may_keep_b);
        }
        let mut best: Option<Choice> = None;
        // Keeps the choice with the lower (cost, error); the first one considered wins a tie.
        let mut consider = |keep: Keep, position: DVec3, cost: f64, error: f64| {
            if best.as_ref().is_none_or(|c| (cost, error) < (c.cost, c.error)) {
                best = Some(Choice { cost, error, keep, position });
            }
        };
        let q = va.quadric + vb.quadric;
        match self.config.options.metric {
            Metric::Melax => {
                if may_keep_b {
                    consider(Keep::B, pb, self.melax_cost(a, b), q.error(pb));
                }
                if may_keep_a {
                    consider(Keep::A, pa, self.melax_cost(b, a), q.error(pa));
                }
            }
            Metric::Qem | Metric::Qfvp { .. } => {
                // The normal term depends on the edge only, not on where the merged vertex goes,
                // so every placement of this edge is ranked by its quadric error alone.
                let factor = self.normal_factor(va, vb);
                let mover = match (may_keep_a, may_keep_b) {
                    (true, false) => Keep::A,
                    (false, true) => Keep::B,
                    _ => Keep::Larger,
                };
                let on_boundary = ka == VertexKind::Boundary && kb == VertexKind::Boundary;
                // (Checked here: a call per ranking costs a mesh without attribute quadrics ~2%.)
                // The survivor is resolved only for the attribute quadrics: that of a moving
                // collapse reads both fans' lengths, and when every edge is first ranked the fans
                // of its higher end are not in cache (half of this function's time there, perf).
                let weighted = self.terms.wedges.is_some();
                let appearance = |keep: Keep, p: DVec3| {
                    if weighted {
                        let survivor = self.survivor(keep, a, b);
                        self.attribute_error(survivor, survivor ^ a ^ b, p)
                    } else {
                        0.0
                    }
                };
                let optimal = may_move && self.config.options.placement == Placement::Optimal;
                if optimal
                    && !on_boundary
                    && let Some(p) = q.minimizer()
                    && (p - (pa + pb) * 0.5).length_squared() <= (pa - pb).length_squared()
                {
                    // The minimiser of vᵀQv, when well conditioned and within one edge length of
                    // the midpoint (a nearly singular system can run far off), has the lowest
                    // error of all placements: nothing else needs evaluating.
                    let error = q.error(p);
                    let cost = (error + appearance(mover, p)) * factor;
                    return Some(Choice { cost, error, keep: mover, position: p });
                }
                let (e_a, e_b) = (q.error(pa), q.error(pb));
                if may_keep_a {
                    consider(Keep::A, pa, (e_a + appearance(Keep::A, pa)) * factor, e_a);
                }
                if may_keep_b {
                    consider(Keep::B, pb, (e_b + appearance(Keep::B, pb)) * factor, e_b);
                }
                if may_move && self.config.options.placement != Placement::Endpoint {
                    let mid = (pa + pb) * 0.5;
                    let e_mid = q.error(mid);
                    consider(mover, mid, (e_mid + appearance(mover, mid)) * factor, e_mid);
                    if optimal && on_boundary {
                        // A boundary edge's vertex stays on the edge: the best point of the segment
                        // (the error along it is a parabola through its values at 0, ½ and 1).
                        let curvature = e_a - 2.0 * e_mid + e_b;
                        if curvature > 0.0 {
                            let t = (0.25 * (3.0 * e_a - 4.0 * e_mid + e_b) / curvature).clamp(0.0, 1.0);
                            let p = pa + (pb - pa) * t;
                            let error = q.error(p);
                            consider(mover, p, (error + appearance(mover, p)) * factor, error);
                        }
                    }
                }
            }
        }
        best
    }

    /// The endpoints alone, without attribute quadrics (every ranking on a mesh with texture
    /// coordinates, whose `auto` placement is `endpoint`): the choice of [`State::choose`]'s
    /// general path, the same operations in the same order, without its closures.
    #[inline]
    fn endpoints_only(
        &self,
        va: &VertexData,
        vb: &VertexData,
        (pa, pb): (DVec3, DVec3),
        may_keep_a: bool,
        may_keep_b: bool,
    ) -> Option<Choice> {
        let q = va.quadric + vb.quadric;
        let factor = self.normal_factor(va, vb);
        let (e_a, e_b) = (q.error(pa), q.error(pb));
        let (cost_a, cost_b) = ((e_a + 0.0) * factor, (e_b + 0.0) * factor);
        let take_b = may_keep_b && (!may_keep_a || (cost_b, e_b) < (cost_a, e_a));
        match (may_keep_a, take_b) {
            (_, true) => Some(Choice { cost: cost_b, error: e_b, keep: Keep::B, position: pb }),
            (true, false) => Some(Choice { cost: cost_a, error: e_a, keep: Keep::A, position: pa }),
            (false, false) => None,
        }
    }

    /// Which ends of edge {a, b} (of classes `ka`, `kb`) may survive its collapse, and whether the
    /// survivor may move: `(keep a, keep b, move)`, or `None` when the rules forbid every way.
    #[inline]
    fn allowed(&self, a: u32, b: u32, ka: VertexKind, kb: VertexKind) -> Option<(bool, bool, bool)> {
        let lock = self.config.options.boundary == BoundaryMode::Lock;
        // A frozen vertex stays where it is, as an anchor does, and takes in a neighbour only
        // where its own edges to the collapse's opposite vertices are manifold (rule 1, checked
        // with the link condition in `is_legal`).
        let stays = |k: VertexKind| matches!(k, VertexKind::Anchored | VertexKind::Frozen);
        // Which endpoints may survive, and whether the survivor may move.
        let (may_keep_a, may_keep_b, may_move) = match (ka, kb) {
            _ if stays(ka) && stays(kb) => return None,
            (VertexKind::Locked, _) | (_, VertexKind::Locked) => return None,
            // A boundary vertex goes into an anchor only along its boundary.
            (_, VertexKind::Boundary) | (VertexKind::Boundary, _)
                if (stays(ka) || stays(kb)) && self.edge_corners(a, b).1 != 1 =>
            {
                return None;
            }
            _ if stays(ka) => (true, false, false),
            _ if stays(kb) => (false, true, false),
            (VertexKind::Boundary, VertexKind::Boundary) => {
                if lock || self.edge_corners(a, b).1 != 1 {
                    return None; // interior edge joining two boundary points, or locked border
                }
                (true, true, true)
            }
            (VertexKind::Boundary, _) => (true, false, false),
            (_, VertexKind::Boundary) => (false, true, false),
            _ => (true, true, true),
        };
        // With attributes, an edge with one end on a seam keeps that end where it is (rule 7).
        if self.seams.on_seam.is_empty() {
            return Some((may_keep_a, may_keep_b, may_move));
        }
        match (self.seams.on_seam[a as usize], self.seams.on_seam[b as usize]) {
            (true, false) if may_keep_a => Some((true, false, false)),
            (false, true) if may_keep_b => Some((false, true, false)),
            (true, false) | (false, true) => None,
            _ => Some((may_keep_a, may_keep_b, may_move)),
        }
    }
}
