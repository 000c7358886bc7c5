//! What an [`ObservationRef`] of the merged set is, for people: its kind, id, epoch and where it lies.

use plumbline_adjustment::{ObservationRef, ObservationSetV1};

/// The report's kind of an observation: `tie`, `pole` or `gnss`.
pub fn kind(item: &ObservationRef) -> &'static str {
    match item {
        ObservationRef::Pole { .. } => "pole",
        ObservationRef::Gnss { .. } => "gnss",
        ObservationRef::TieRay { .. } | ObservationRef::TieAerial { .. } | ObservationRef::Tie { .. } => "tie",
    }
}

/// Its id: the cadastre id, `gnss[i]`, the tie point id (with `.rays[r]` or `.aerial` for a part).
pub fn id(item: &ObservationRef) -> String {
    match item {
        ObservationRef::Pole { cadastre_id, .. } => cadastre_id.clone(),
        ObservationRef::Gnss { index } => format!("gnss[{index}]"),
        ObservationRef::TieRay { point, ray, .. } => format!("{}.rays[{ray}]", point.0),
        ObservationRef::TieAerial { point, .. } => format!("{}.aerial", point.0),
        ObservationRef::Tie { point, .. } => point.0.clone(),
    }
}

/// Its epoch (a tie point: the ray's, or the first ray's).
pub fn time(set: &ObservationSetV1, item: &ObservationRef) -> Option<f64> {
    match item {
        ObservationRef::Pole { index, .. } => set.poles.get(*index).map(|p| p.time),
        ObservationRef::Gnss { index } => set.gnss.get(*index).map(|g| g.time),
        ObservationRef::TieRay { index, ray, .. } => {
            set.ties.get(*index).and_then(|t| t.rays.get(*ray)).map(|r| r.time)
        }
        ObservationRef::TieAerial { index, .. } | ObservationRef::Tie { index, .. } => {
            set.ties.get(*index).and_then(|t| t.rays.first()).map(|r| r.time)
        }
    }
}

/// Where it lies in the map, when the observation itself says (pole: the cadastre position; GNSS: the
/// antenna; tie: the aerial coordinates).
pub fn place(set: &ObservationSetV1, item: &ObservationRef) -> Option<[f64; 2]> {
    match item {
        ObservationRef::Pole { index, .. } => set.poles.get(*index).map(|p| p.cadastre),
        ObservationRef::Gnss { index } => set.gnss.get(*index).map(|g| [g.position[0], g.position[1]]),
        ObservationRef::TieRay { index, .. }
        | ObservationRef::TieAerial { index, .. }
        | ObservationRef::Tie { index, .. } => {
            set.ties.get(*index).and_then(|t| t.aerial).map(|a| [a.position[0], a.position[1]])
        }
    }
}

/// The index of the tie point, pole or GNSS position an item belongs to, with its kind.
pub fn owner(item: &ObservationRef) -> (&'static str, usize) {
    match item {
        ObservationRef::Pole { index, .. } => ("pole", *index),
        ObservationRef::Gnss { index } => ("gnss", *index),
        ObservationRef::TieRay { index, .. }
        | ObservationRef::TieAerial { index, .. }
        | ObservationRef::Tie { index, .. } => ("tie", *index),
    }
}
