//! `CampaignId`: the validated identifier a campaign is known by in storage keys, subjects and reports.

use std::borrow::Cow;
use std::fmt;
use std::str::FromStr;

use schemars::{JsonSchema, Schema, SchemaGenerator, json_schema};
use serde::{Deserialize, Serialize};

/// The longest identifier accepted; it becomes part of object-store keys and NATS subjects.
pub const MAX_CAMPAIGN_ID_LEN: usize = 64;

/// A campaign identifier: 1 to 64 characters out of `a`–`z`, `0`–`9`, `-` and `_`.
///
/// Checked when parsed, so every `CampaignId` is safe to use in keys and subjects.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub struct CampaignId(String);

/// Why a string is not a [`CampaignId`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CampaignIdError {
    #[error("campaign id is empty; expected 1 to {MAX_CAMPAIGN_ID_LEN} characters")]
    Empty,
    #[error("campaign id has {0} characters; expected at most {MAX_CAMPAIGN_ID_LEN}")]
    TooLong(usize),
    #[error("campaign id contains {0:?}; expected only lowercase letters a-z, digits, '-' and '_'")]
    BadCharacter(char),
}

impl CampaignId {
    /// The identifier as a string slice.
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl FromStr for CampaignId {
    type Err = CampaignIdError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::try_from(s.to_owned())
    }
}

impl TryFrom<String> for CampaignId {
    type Error = CampaignIdError;

    fn try_from(s: String) -> Result<Self, Self::Error> {
        let len = s.chars().count();
        if len == 0 {
            return Err(CampaignIdError::Empty);
        }
        if len > MAX_CAMPAIGN_ID_LEN {
            return Err(CampaignIdError::TooLong(len));
        }
        match s.chars().find(|c| !matches!(c, 'a'..='z' | '0'..='9' | '-' | '_')) {
            Some(bad) => Err(CampaignIdError::BadCharacter(bad)),
            None => Ok(Self(s)),
        }
    }
}

impl From<CampaignId> for String {
    fn from(id: CampaignId) -> Self {
        id.0
    }
}

impl fmt::Display for CampaignId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl JsonSchema for CampaignId {
    fn schema_name() -> Cow<'static, str> {
        "CampaignId".into()
    }

    fn json_schema(_: &mut SchemaGenerator) -> Schema {
        json_schema!({
            "description": "Campaign identifier: 1 to 64 characters out of a-z, 0-9, '-' and '_'.",
            "type": "string",
            "pattern": "^[a-z0-9_-]{1,64}$",
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(input: &str, expect: Result<(), CampaignIdError>) {
        let got = input.parse::<CampaignId>().map(|id| assert_eq!(id.as_str(), input));
        assert_eq!(got, expect, "{input:?}");
    }

    #[test]
    fn accepts_and_rejects() {
        check("hamburg-2024_q3", Ok(()));
        check("a", Ok(()));
        check(&"x".repeat(64), Ok(()));
        check("", Err(CampaignIdError::Empty));
        check(&"x".repeat(65), Err(CampaignIdError::TooLong(65)));
        check("Hamburg", Err(CampaignIdError::BadCharacter('H')));
        check("hh 2024", Err(CampaignIdError::BadCharacter(' ')));
        check("hh/2024", Err(CampaignIdError::BadCharacter('/')));
        check("straße", Err(CampaignIdError::BadCharacter('ß')));
    }
}
