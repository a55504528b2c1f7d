//! The contract's status codes where tonic's codec answers for us: a request body that does not
//! decode is INVALID_ARGUMENT (tonic says INTERNAL), a message over the size limit is
//! RESOURCE_EXHAUSTED (tonic says OUT_OF_RANGE). Unary calls are answered in the response
//! headers, which this layer rewrites; streamed uploads meet the same errors in the handler, which
//! maps them with [`contract_status`].
//!
//! The same layer reads each call's `grpc-timeout` into [`CallDeadline`] (tonic keeps the header
//! from the handlers), so that a call that outlives its deadline is counted as DEADLINE_EXCEEDED.

use std::convert::Infallible;
use std::future::Future;
use std::pin::Pin;
use std::task::{Context, Poll};
use std::time::{Duration, Instant};

use tonic::Status;
use tonic::server::NamedService;

/// The status the contract promises for a codec error, if `code` and `message` are one.
fn contract_code(code: tonic::Code, message: &str) -> Option<tonic::Code> {
    match code {
        tonic::Code::Internal if message.starts_with("failed to decode Protobuf message") => {
            Some(tonic::Code::InvalidArgument)
        }
        tonic::Code::OutOfRange if message.contains("message length too large") => Some(tonic::Code::ResourceExhausted),
        _ => None,
    }
}

/// A call's deadline: when it passes, by this server's clock (its `grpc-timeout` from when its
/// headers arrived), and the timeout itself.
#[derive(Debug, Clone, Copy)]
pub struct CallDeadline {
    /// The deadline by this server's clock.
    pub at: Instant,
    /// The timeout the call was sent with.
    pub timeout: Duration,
}

impl CallDeadline {
    /// Whether a call dropped now ended at its deadline. The client's clock started before the
    /// headers arrived (encoding, connecting, sending), so its timer fires before this one: a drop
    /// within a quarter of the timeout (at most a second) of the deadline counts as expiry, any
    /// earlier one as the client's cancellation.
    pub fn expired(&self) -> bool {
        let slack = (self.timeout / 4).min(Duration::from_secs(1));
        Instant::now() + slack >= self.at
    }
}

/// A `grpc-timeout` value: digits and a unit (H, M, S, m, u, n).
fn parse_timeout(value: &str) -> Option<Duration> {
    let (digits, unit) = value.split_at(value.len().checked_sub(1)?);
    let n: u64 = digits.parse().ok()?;
    Some(match unit {
        "H" => Duration::from_secs(n.saturating_mul(3600)),
        "M" => Duration::from_secs(n.saturating_mul(60)),
        "S" => Duration::from_secs(n),
        "m" => Duration::from_millis(n),
        "u" => Duration::from_micros(n),
        "n" => Duration::from_nanos(n),
        _ => return None,
    })
}

/// A codec error from a request stream, with the contract's code.
pub fn contract_status(status: Status) -> Status {
    match contract_code(status.code(), status.message()) {
        Some(code) => Status::new(code, format!("request: {}", status.message())),
        None => status,
    }
}

/// Wraps the MeshLod service, rewriting codec errors' codes in trailers-only responses.
#[derive(Clone)]
pub struct ContractCodes<S>(pub S);

impl<S: NamedService> NamedService for ContractCodes<S> {
    const NAME: &'static str = S::NAME;
}

impl<S, B, RB> tower::Service<http::Request<B>> for ContractCodes<S>
where
    S: tower::Service<http::Request<B>, Response = http::Response<RB>, Error = Infallible>,
    S::Future: Send + 'static,
{
    type Response = http::Response<RB>;
    type Error = Infallible;
    type Future = Pin<Box<dyn Future<Output = Result<Self::Response, Infallible>> + Send>>;

    fn poll_ready(&mut self, cx: &mut Context<'_>) -> Poll<Result<(), Infallible>> {
        self.0.poll_ready(cx)
    }

    fn call(&mut self, mut request: http::Request<B>) -> Self::Future {
        let timeout = request.headers().get("grpc-timeout").and_then(|v| v.to_str().ok()).and_then(parse_timeout);
        if let Some(d) = timeout {
            request.extensions_mut().insert(CallDeadline { at: Instant::now() + d, timeout: d });
        }
        let future = self.0.call(request);
        Box::pin(async move {
            let mut response = future.await?;
            let headers = response.headers_mut();
            let code = headers.get("grpc-status").and_then(|v| v.to_str().ok()).and_then(|v| v.parse::<i32>().ok());
            let message =
                headers.get("grpc-message").and_then(|v| v.to_str().ok()).map(percent_decode).unwrap_or_default();
            if let Some(new) = code.and_then(|c| contract_code(tonic::Code::from_i32(c), &message)) {
                headers.insert("grpc-status", http::HeaderValue::from(new as i32));
            }
            Ok(response)
        })
    }
}

/// The grpc-message header is percent-encoded.
fn percent_decode(text: &str) -> String {
    let bytes = text.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%'
            && i + 2 < bytes.len()
            && let Ok(v) = u8::from_str_radix(&text[i + 1..i + 3], 16)
        {
            out.push(v);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}
