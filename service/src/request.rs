//! What a job is asked to do, in the engine's terms plus what the service adds: the command line
//! fills it from its flags, the server from the contract's options (`crate::convert`), and a
//! client turns it into the contract's options to send.

use meshlod_engine::refine::RefineMode;
use meshlod_engine::simplify::SimplifyOptions;

/// How a simplification's w is chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum WChoice {
    /// The one given (QFVP's exponent; with another metric it changes nothing, and is said).
    Given(f64),
    /// The predictor's.
    Auto,
    /// Each of the classes tried, the result with the lowest measured distance kept.
    Search,
}

/// A simplification as the jobs take it: the engine's options (targets, cost, placement, rules;
/// w is 0 in them while `w` is `Auto` or `Search`), how w is chosen, and what the service adds: the
/// measured distance and the form of the `.pm` file. The command line fills it from its flags; the
/// server from the contract's options (`crate::convert`).
#[derive(Debug, Clone)]
pub struct SimplifyRequest {
    /// The engine's options.
    pub options: SimplifyOptions,
    /// How w is chosen.
    pub w: WChoice,
    /// Measure the result against the input (certified Hausdorff bounds).
    pub compute_hausdorff: bool,
    /// The `.pm` file with every float as it is, rather than the compact form.
    pub progressive_lossless: bool,
    /// Compare input and result in pixels (`meshlod compare`'s default views).
    pub compare: bool,
}

/// How a refinement's ETC (energy threshold coefficient) is chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EtcChoice {
    /// The one given.
    Given(f64),
    /// The predictor's estimate for the target face count.
    Auto,
    /// Searched: the ETC that reaches the target face count.
    Search,
}

/// A refinement as the jobs take it.
#[derive(Debug, Clone, PartialEq)]
pub struct RefineRequest {
    /// How the ETC is chosen.
    pub etc: EtcChoice,
    /// Faces to reach (with `Auto` or `Search`).
    pub target_faces: Option<usize>,
    /// What to do; `None`: the direction that reaches the target, else subdivision.
    pub mode: Option<RefineMode>,
    /// Subdivision rounds.
    pub rounds: u32,
}
