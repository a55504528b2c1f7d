//! The bearer token check of every MeshLod call, when the server has a token.

use std::sync::Arc;

use tonic::{Request, Status};

/// Checks `authorization: Bearer <token>` (the scheme in any case, as RFC 7235 has it) against the
/// configured token, in time that does not depend on where the two differ.
#[derive(Clone)]
pub struct TokenCheck(Option<Arc<[u8]>>);

impl TokenCheck {
    /// A check for `token`; `None` lets every call through.
    pub fn new(token: Option<&str>) -> TokenCheck {
        TokenCheck(token.map(|t| Arc::from(t.as_bytes())))
    }
}

/// Whether `a` equals `b`, reading every byte of both whatever they hold (only the lengths, which
/// a token's format fixes, can be told apart by time).
fn equal_in_constant_time(a: &[u8], b: &[u8]) -> bool {
    if a.len() != b.len() {
        return false;
    }
    let difference = a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y));
    std::hint::black_box(difference) == 0
}

/// The token of an `authorization` header value, if it uses the Bearer scheme.
fn bearer_token(value: &str) -> Option<&str> {
    let (scheme, token) = value.trim().split_once(' ')?;
    scheme.eq_ignore_ascii_case("bearer").then(|| token.trim_start())
}

impl tonic::service::Interceptor for TokenCheck {
    fn call(&mut self, request: Request<()>) -> Result<Request<()>, Status> {
        let Some(expected) = &self.0 else { return Ok(request) };
        let header = request.metadata().get("authorization");
        let value = header.map(|v| v.to_str().map_err(|_| Status::unauthenticated("authorization: not text")));
        match value.transpose()?.map(bearer_token) {
            Some(Some(token)) if equal_in_constant_time(token.as_bytes(), expected) => Ok(request),
            Some(Some(_)) => Err(Status::unauthenticated("invalid bearer token")),
            Some(None) => Err(Status::unauthenticated("authorization: expected the Bearer scheme (Bearer <token>)")),
            None => Err(Status::unauthenticated("missing authorization: Bearer <token>")),
        }
    }
}

#[cfg(test)]
mod tests {
    use tonic::service::Interceptor;

    use super::*;

    fn call(check: &mut TokenCheck, header: Option<&str>) -> Result<(), tonic::Code> {
        let mut request = Request::new(());
        if let Some(h) = header {
            request.metadata_mut().insert("authorization", h.parse().unwrap());
        }
        check.call(request).map(|_| ()).map_err(|s| s.code())
    }

    #[test]
    fn the_scheme_is_case_insensitive_and_the_token_exact() {
        let mut check = TokenCheck::new(Some("s3cret"));
        assert_eq!(call(&mut check, Some("Bearer s3cret")), Ok(()));
        assert_eq!(call(&mut check, Some("bearer s3cret")), Ok(()));
        assert_eq!(call(&mut check, Some("BEARER  s3cret")), Ok(()));
        assert_eq!(call(&mut check, Some("Bearer s3cres")), Err(tonic::Code::Unauthenticated));
        assert_eq!(call(&mut check, Some("Bearer s3cret2")), Err(tonic::Code::Unauthenticated));
        assert_eq!(call(&mut check, Some("Basic s3cret")), Err(tonic::Code::Unauthenticated));
        assert_eq!(call(&mut check, None), Err(tonic::Code::Unauthenticated));
        assert_eq!(call(&mut TokenCheck::new(None), None), Ok(()));
        assert!(equal_in_constant_time(b"abc", b"abc"));
        assert!(!equal_in_constant_time(b"abc", b"abd"));
        assert!(!equal_in_constant_time(b"abc", b"ab"));
    }
}
