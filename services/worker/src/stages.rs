//! The stages a tile output times ([`Timed`], by their stable names in `TileOutputV1::seconds`), at the
//! bottom of the worker (it imports no other module). Progress and skipped items name the campaign's
//! [`plumbline_campaign::Stage`]s.

/// The stages a tile output times (`TileOutputV1::seconds`), written and read by their stable names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Timed {
    /// Reading the registration's inputs (panoramas, mask, aerial frames or rasters).
    Read,
    /// Decoding them.
    Decode,
    /// Ortho patches of the panoramas (thread-seconds).
    Ortho,
    /// KAZE features of the panoramas (thread-seconds).
    Features,
    /// Preparing the panoramas: read, decode, ortho and features together (wall time).
    Prepare,
    /// MM matching of neighbouring panoramas (thread-seconds).
    Matching,
    /// Ray intersection (thread-seconds).
    Triangulation,
    /// Aerial matching and triangulation (thread-seconds).
    Aerial,
    /// Road-marking extraction from the ortho patches (thread-seconds).
    Lines,
    /// The whole registration (wall time).
    Registration,
    /// Reading the depth images and the cadastre.
    PolesRead,
    /// The pole pipeline.
    Poles,
    /// The whole tile.
    Total,
}

impl Timed {
    /// Every timed stage, in the order a tile output lists them.
    pub(crate) const ALL: [Self; 13] = [
        Self::Read,
        Self::Decode,
        Self::Ortho,
        Self::Features,
        Self::Prepare,
        Self::Matching,
        Self::Triangulation,
        Self::Aerial,
        Self::Lines,
        Self::Registration,
        Self::PolesRead,
        Self::Poles,
        Self::Total,
    ];

    /// The stable name in `TileOutputV1::seconds`.
    pub(crate) const fn name(self) -> &'static str {
        match self {
            Self::Read => "read",
            Self::Decode => "decode",
            Self::Ortho => "ortho",
            Self::Features => "features",
            Self::Prepare => "prepare",
            Self::Matching => "matching",
            Self::Triangulation => "triangulation",
            Self::Aerial => "aerial",
            Self::Lines => "lines",
            Self::Registration => "registration",
            Self::PolesRead => "poles_read",
            Self::Poles => "poles",
            Self::Total => "total",
        }
    }

    /// The stage a name in `seconds` stands for, if it is one.
    pub(crate) fn of(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|t| t.name() == name)
    }

    /// This stage's entry of `seconds`.
    pub(crate) fn took(self, seconds: f64) -> (String, f64) {
        (self.name().to_owned(), seconds)
    }
}
