//! Bearer tokens of the job API: `tokens.toml` maps each token to the agency it acts for.
//!
//! ```toml
//! [tokens]
//! "hh-6f1c9e2a0b7d4c58a3e1" = "hamburg"   # token = agency
//! "hh-second-token-0001ab" = "hamburg"    # an agency may hold several (rotation)
//! "hb-0d2e8f71c6a94b3e9b55" = "bremen"
//! ```
//!
//! Agency names follow the campaign-id rules (`a`–`z`, `0`–`9`, `-`, `_`): they become the object prefix
//! `agencies/<agency>/`. Tokens are [`Secret`]s: never logged, compared in constant time, at least
//! [`MIN_TOKEN_LEN`] characters. Errors name the entry by position, never by its token.

use std::collections::BTreeMap;

pub use crate::messages::Agency;
use plumbline_runtime::Secret;
use serde::Deserialize;

/// Shortest token accepted.
pub const MIN_TOKEN_LEN: usize = 16;

/// The token set.
#[derive(Clone, Debug, Default)]
pub struct Tokens {
    entries: Vec<(Secret, Agency)>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TokensFile {
    tokens: BTreeMap<String, String>,
}

impl Tokens {
    /// Parse `tokens.toml`; `origin` names the file in errors.
    pub fn from_toml(origin: &str, text: &str) -> Result<Self, String> {
        let file: TokensFile = toml::from_str(text).map_err(|e| {
            let line = e.span().map_or(0, |s| text[..s.start.min(text.len())].lines().count().max(1));
            format!("{origin}: line {line}: {}", e.message())
        })?;
        let mut entries = Vec::with_capacity(file.tokens.len());
        for (i, (token, agency)) in file.tokens.into_iter().enumerate() {
            let entry = || format!("{origin}: tokens entry {} (agency {agency:?})", i + 1);
            if token.chars().count() < MIN_TOKEN_LEN {
                return Err(format!("{}: token shorter than {MIN_TOKEN_LEN} characters", entry()));
            }
            let agency_id = Agency::parse(&agency).map_err(|e| format!("{}: {e}", entry()))?;
            entries.push((Secret::new(token), agency_id));
        }
        if entries.is_empty() {
            return Err(format!("{origin}: [tokens] is empty; no agency could use the API"));
        }
        Ok(Self { entries })
    }

    /// A token set from pairs (for tests and embedding).
    pub fn from_pairs(pairs: &[(&str, &str)]) -> Result<Self, String> {
        let text: String = std::iter::once("[tokens]\n".to_owned())
            .chain(pairs.iter().map(|(t, a)| format!("{t:?} = {a:?}\n")))
            .collect();
        Self::from_toml("tokens", &text)
    }

    /// The agency holding `token`, comparing against every entry in constant time per entry.
    pub fn agency(&self, token: &str) -> Option<Agency> {
        let mut found = None;
        for (secret, agency) in &self.entries {
            if constant_time_eq(secret.expose().as_bytes(), token.as_bytes()) {
                found = Some(agency.clone());
            }
        }
        found
    }

    /// The agency of an `Authorization` header value (`Bearer <token>`; the scheme is case-insensitive, as
    /// HTTP auth schemes are).
    pub fn authorize(&self, header: Option<&str>) -> Option<Agency> {
        let (scheme, token) = header?.trim_start().split_once(' ')?;
        if !scheme.eq_ignore_ascii_case("bearer") {
            return None;
        }
        self.agency(token.trim())
    }
}

fn constant_time_eq(a: &[u8], b: &[u8]) -> bool {
    if a.len() != b.len() {
        return false;
    }
    a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

#[cfg(test)]
mod tests {
    use super::*;

    const FILE: &str = "[tokens]\n\"hh-0123456789abcdef\" = \"hamburg\"\n\"hb-0123456789abcdef\" = \"bremen\"\n";

    #[test]
    fn tokens_map_to_their_agency() {
        let tokens = Tokens::from_toml("tokens.toml", FILE).unwrap();
        assert_eq!(tokens.agency("hh-0123456789abcdef").unwrap().as_str(), "hamburg");
        assert_eq!(tokens.authorize(Some("Bearer hb-0123456789abcdef")).unwrap().as_str(), "bremen");
        assert_eq!(tokens.authorize(Some("bearer hb-0123456789abcdef")).unwrap().as_str(), "bremen");
        assert_eq!(tokens.authorize(Some("BEARER  hb-0123456789abcdef")).unwrap().as_str(), "bremen");
        assert_eq!(tokens.authorize(Some("Basic hb-0123456789abcdef")), None);
        assert_eq!(tokens.authorize(Some("Bearer hb-0123456789abcdeX")), None);
        assert_eq!(tokens.authorize(Some("hb-0123456789abcdef")), None, "scheme required");
        assert_eq!(tokens.authorize(None), None);
    }

    #[test]
    fn bad_files_are_named_without_showing_tokens() {
        let short = Tokens::from_toml("t.toml", "[tokens]\n\"secret-x\" = \"hamburg\"\n").unwrap_err();
        assert!(short.contains("t.toml") && short.contains("shorter"), "{short}");
        assert!(!short.contains("secret-x"), "{short}");
        let bad = Tokens::from_toml("t.toml", "[tokens]\n\"secret-0123456789ab\" = \"Ham burg\"\n").unwrap_err();
        assert!(bad.contains("agency") && !bad.contains("secret-0123"), "{bad}");
        let syntax = Tokens::from_toml("t.toml", "[tokens]\n\"secret-0123456789ab\" = \n").unwrap_err();
        assert!(syntax.contains("line 2") && !syntax.contains("secret-0123"), "{syntax}");
        assert!(Tokens::from_toml("t.toml", "[tokens]\n").unwrap_err().contains("empty"));
        assert!(format!("{:?}", Tokens::from_toml("t", FILE).unwrap()).contains("***"));
    }
}
