//! The terms a collapse pays beside its quadric cost, owned by one part of the state
//! ([`Terms`]): the distance guard, the fan-distance term, the attribute quadrics.

use super::attribute_quadric::WedgeQuadrics;
use super::guard::DistanceGuard;

/// The distance terms and the attribute quadrics of a run.
pub(crate) struct Terms {
    /// What the distance guard measures with, when it is on.
    pub(crate) guard: Option<DistanceGuard>,
    /// Weight of the fan-distance term (`super::fan_term`): the options' where it applies (a
    /// quadric cost, the distance guard off, no texture coordinates), else 0.
    pub(crate) fan_term: f64,
    /// Whether the queue ranks quadric costs per unit of the area behind them
    /// (`State::ranked_cost`): with a distance term (the fan-distance term or the guard's), not
    /// with the paper's cost alone.
    pub(crate) per_area: bool,
    /// The face count whose share `super::fan_term::FAN_TERM_FROM` the run removes before the
    /// fan-distance term is measured: the mesh's own, or the whole input's for the second stage of
    /// a run in halves (`super::halves`).
    pub(crate) term_base: usize,
    /// The attribute quadrics of the wedges ([`WedgeQuadrics`]), when attributes are carried and
    /// weighted.
    pub(crate) wedges: Option<WedgeQuadrics>,
}

impl Terms {
    /// Whether queue keys leave out a distance term that candidates pay when they reach the top
    /// (the distance guard's or the fan-distance term).
    pub(crate) fn has_distance_term(&self) -> bool {
        self.guard.is_some() || self.fan_term > 0.0
    }
}
