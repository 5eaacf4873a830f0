//! Who may read the pages: anyone who reaches a localhost address, and — only when a token
//! was given — whoever shows it on any other address. The pages name a fleet's wheels and
//! their flats; an operator who wants them on the network either gives a token or puts the
//! server behind a reverse proxy that authenticates (docs/serve.md).

use super::error::ServeError;
use axum::extract::{Request, State};
use axum::http::{header, StatusCode};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use sha2::{Digest, Sha256};
use std::net::SocketAddr;
use std::sync::Arc;

/// The shortest token accepted (characters).
pub const MIN_TOKEN_CHARS: usize = 16;
/// The longest token file read (bytes).
pub const MAX_TOKEN_FILE_BYTES: u64 = 4096;

/// A shared secret a request shows as `Authorization: Bearer <token>`, or once as
/// `?token=<token>` (the browser then keeps it in a cookie for this server).
#[derive(Clone)]
pub struct Token {
    digest: [u8; 32],
}

impl std::fmt::Debug for Token {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Token(…)")
    }
}

impl Token {
    /// The token in `text` (surrounding white space removed), refused when shorter than
    /// [`MIN_TOKEN_CHARS`] or holding other than letters, digits and `-_.~`.
    pub fn new(text: &str) -> Result<Token, ServeError> {
        let t = text.trim();
        if t.chars().count() < MIN_TOKEN_CHARS {
            return Err(ServeError::Token(format!(
                "the token has {} characters; at least {MIN_TOKEN_CHARS} are needed",
                t.chars().count()
            )));
        }
        if !t
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || b"-_.~".contains(&b))
        {
            return Err(ServeError::Token(
                "the token may hold letters, digits and `-_.~` only (it travels in a URL and a cookie)".into(),
            ));
        }
        Ok(Token {
            digest: Sha256::digest(t.as_bytes()).into(),
        })
    }

    /// Whether `shown` is the token. Compared as SHA-256 digests, every byte looked at, so
    /// the time taken says nothing of how much of it matched.
    pub fn matches(&self, shown: &str) -> bool {
        let d: [u8; 32] = Sha256::digest(shown.trim().as_bytes()).into();
        d.iter()
            .zip(self.digest.iter())
            .fold(0u8, |acc, (a, b)| acc | (a ^ b))
            == 0
    }
}

/// Refuses an address other than a loopback one when there is no token.
pub fn check_listen(addr: SocketAddr, has_token: bool) -> Result<(), ServeError> {
    if addr.ip().is_loopback() || has_token {
        Ok(())
    } else {
        Err(ServeError::Exposed { addr })
    }
}

/// The cookie a browser keeps the token in after `?token=`.
const COOKIE: &str = "wheelflat_token";

/// Lets a request through when no token is set or it shows the token; otherwise 401.
pub(super) async fn require_token(
    State(token): State<Option<Arc<Token>>>,
    request: Request,
    next: Next,
) -> Response {
    let Some(token) = token else {
        return next.run(request).await;
    };
    let headers = request.headers();
    let bearer = headers
        .get(header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.strip_prefix("Bearer "));
    let cookie = headers
        .get_all(header::COOKIE)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(';'))
        .filter_map(|kv| kv.trim().strip_prefix(COOKIE)?.strip_prefix('='))
        .next();
    if bearer.or(cookie).is_some_and(|t| token.matches(t)) {
        return next.run(request).await;
    }
    let query = request.uri().query().and_then(|q| {
        form_urlencoded::parse(q.as_bytes())
            .find(|(k, _)| k == "token")
            .map(|(_, v)| v.into_owned())
    });
    if let Some(t) = query.filter(|t| token.matches(t)) {
        let mut response = next.run(request).await;
        if let Ok(v) = format!("{COOKIE}={t}; HttpOnly; SameSite=Strict; Path=/").parse() {
            response.headers_mut().insert(header::SET_COOKIE, v);
        }
        return response;
    }
    (
        StatusCode::UNAUTHORIZED,
        "this wheelflat server needs its token: `Authorization: Bearer <token>`, or open the page once with ?token=<token>\n",
    )
        .into_response()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_short_or_spaced_token_is_refused_and_only_the_token_matches() {
        assert!(Token::new("short").is_err());
        assert!(Token::new("sixteen chars ok").is_err());
        let t = Token::new("  abcdefghijklmnop\n").unwrap();
        assert!(t.matches("abcdefghijklmnop"));
        assert!(!t.matches("abcdefghijklmnoq"));
        assert!(!t.matches(""));
    }

    #[test]
    fn only_loopback_listens_without_a_token() {
        assert!(check_listen("127.0.0.1:8080".parse().unwrap(), false).is_ok());
        assert!(check_listen("[::1]:8080".parse().unwrap(), false).is_ok());
        assert!(check_listen("0.0.0.0:8080".parse().unwrap(), false).is_err());
        assert!(check_listen("192.168.1.4:80".parse().unwrap(), false).is_err());
        assert!(check_listen("0.0.0.0:8080".parse().unwrap(), true).is_ok());
    }
}
