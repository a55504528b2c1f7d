//! A collapse on its way: the [`Candidate`] the cost prefers, and the [`Legal`] token that the
//! legality checks give it, the only thing the kernel's collapse accepts.

/// A collapse ready to apply: `removed` merges into `survivor`, which moves to `position`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Candidate {
    pub(crate) cost: f64,
    pub(crate) survivor: u32,
    pub(crate) removed: u32,
    pub(crate) position: [f32; 3],
}

/// A collapse that passed `State::is_legal`: the only way to ask for `State::collapse`. It
/// names the check that passed it, so the collapse knows whether that check's new face normals
/// (the state's scratch) are still the ones for this collapse.
#[derive(Debug)]
pub(crate) struct Legal {
    pub(super) candidate: Candidate,
    pub(super) check: u32,
    pub(super) hole: u32,
}

impl Legal {
    /// The collapse that was checked.
    pub(crate) fn candidate(&self) -> &Candidate {
        &self.candidate
    }
}
