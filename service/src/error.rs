//! What can go wrong in a job, in the job's own terms: the request field at fault, as the
//! contract names it (`options.target_ratio`, `input.mesh.indices[7]`), what kind of failure, and
//! why. The jobs and conversions return it; the server maps it onto a gRPC status
//! (`crate::convert`), the command line onto the flag that set the field (`FIELD_FLAGS`).

/// What kind of failure a [`JobError`] is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ErrorKind {
    /// The request (a field of it) is wrong.
    InvalidArgument,
    /// The request is right, but this server cannot do it (no predictor model).
    FailedPrecondition,
    /// The caller went away, or asked to stop.
    Cancelled,
    /// A fault of the service.
    Internal,
}

/// A job's failure: the field at fault (empty when none is), its kind, and the reason.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct JobError {
    /// The request field at fault, as the contract names it; empty when none is.
    pub field: String,
    /// What kind of failure.
    pub kind: ErrorKind,
    /// Why, for people.
    pub reason: String,
}

impl JobError {
    /// The request's `field` is wrong, for `reason`.
    pub fn invalid(field: impl Into<String>, reason: impl Into<String>) -> JobError {
        JobError { field: field.into(), kind: ErrorKind::InvalidArgument, reason: reason.into() }
    }

    /// The request's `field` asks for what this server cannot do.
    pub fn precondition(field: impl Into<String>, reason: impl Into<String>) -> JobError {
        JobError { field: field.into(), kind: ErrorKind::FailedPrecondition, reason: reason.into() }
    }

    /// The request was cancelled.
    pub fn cancelled() -> JobError {
        JobError { field: String::new(), kind: ErrorKind::Cancelled, reason: "request cancelled".into() }
    }

    /// A fault of the service.
    pub fn internal(reason: impl Into<String>) -> JobError {
        JobError { field: String::new(), kind: ErrorKind::Internal, reason: reason.into() }
    }

    /// The command-line flag that sets the field, when one does.
    pub fn flag(&self) -> Option<&'static str> {
        FIELD_FLAGS.iter().find(|(field, _)| *field == self.field).map(|(_, flag)| *flag)
    }
}

impl std::fmt::Display for JobError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.field.is_empty() { write!(f, "{}", self.reason) } else { write!(f, "{}: {}", self.field, self.reason) }
    }
}

impl std::error::Error for JobError {}

/// The command-line flag of each request field a job names.
pub const FIELD_FLAGS: [(&str, &str); 15] = [
    ("options.target_ratio", "--ratio"),
    ("options.target_faces", "--faces"),
    ("options.max_error", "--max-error"),
    ("options.w_search", "--w search"),
    ("options.w_auto", "--w auto"),
    ("options.w", "--w"),
    ("options.guard", "--guard"),
    ("options.distance_term", "--distance-term"),
    ("options.max_normal_change_degrees", "--max-normal-change"),
    ("target_ratio", "--ratio"),
    ("target_faces", "--faces"),
    ("etc_auto", "--etc auto"),
    ("etc", "--etc"),
    ("rounds", "--rounds"),
    ("mode", "--mode"),
];
