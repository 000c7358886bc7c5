//! What [`super::read_cadastre`] and [`super::inspect_cadastre`] share: walking a layer's features with the
//! GDAL failures each fetch raised, and collecting diagnostics in bounded memory.
//!
//! GDAL ends a feature loop early on a corrupted page and hands out a feature without geometry for a
//! blob it cannot decode; both only show in its error handler. [`walk_features`] captures those messages
//! per fetch, so a layer that stopped early is a diagnostic instead of a silently shorter layer, and an
//! undecodable geometry is told apart from a null one.

use std::collections::HashMap;

use gdal::vector::{Feature, Layer, LayerAccess};
use plumbline_campaign::{CadastreDiagnostic, Consequence, DiagnosticKind};

use crate::gdal_messages::capture_failures;

/// Feature-level diagnostics of one (layer, kind) listed one by one; the rest are counted in one closing line.
/// A dropped height is only counted: a 3-D layer gives one line, not one per feature.
const LISTED_PER_KIND: usize = 20;

/// How a layer's walk ended.
#[derive(Debug, Default)]
pub(crate) struct WalkEnd {
    /// Features fetched.
    pub fetched: usize,
    /// The GDAL failure that ended the walk before the layer's end, if any.
    pub stopped_by: Option<String>,
}

/// Calls `each(fid, feature, failures)` for every feature GDAL hands out, `failures` being the GDAL failure
/// messages raised while fetching that feature (e.g. "Unable to read geometry").
pub(crate) fn walk_features(layer: &mut Layer<'_>, mut each: impl FnMut(u64, &Feature<'_>, &[String])) -> WalkEnd {
    let mut end = WalkEnd::default();
    let mut features = layer.features();
    loop {
        let (next, failures) = capture_failures(|| features.next());
        let Some(feature) = next else {
            end.stopped_by = failures.last().cloned();
            return end;
        };
        let fid = feature.fid().unwrap_or(end.fetched as u64);
        end.fetched += 1;
        each(fid, &feature, &failures);
    }
}

/// The diagnostic of a walk that GDAL ended early, when it did: the features read before it are kept.
pub(crate) fn stopped_early(file: &str, layer: &str, end: &WalkEnd, announced: u64) -> Option<CadastreDiagnostic> {
    let message = end.stopped_by.as_ref()?;
    let announced = if announced > end.fetched as u64 { format!(" of {announced}") } else { String::new() };
    Some(CadastreDiagnostic {
        kind: DiagnosticKind::ReadFailed,
        consequence: if end.fetched == 0 { Consequence::LayerSkipped } else { Consequence::Kept },
        file: file.to_owned(),
        layer: layer.to_owned(),
        fid: None,
        field: None,
        detail: format!(
            "reading stopped after {}{announced} features: GDAL: {message} (the file is damaged; the features \
             after that point are lost)",
            end.fetched
        ),
    })
}

/// Diagnostics in reading order, at most [`LISTED_PER_KIND`] feature-level ones per (layer, kind); the others
/// are counted and summarised by [`Diagnostics::finish`].
#[derive(Debug, Default)]
pub(crate) struct Diagnostics {
    listed: Vec<CadastreDiagnostic>,
    /// Per (layer, kind, consequence): how many were not listed, the first of them, and where in `listed` it
    /// came (the closing line takes that place, so the order stays the reading order).
    unlisted: HashMap<(String, DiagnosticKind, Consequence), (u64, CadastreDiagnostic, usize)>,
    /// Per (layer, kind, consequence): how many were listed.
    seen: HashMap<(String, DiagnosticKind, Consequence), usize>,
}

impl Diagnostics {
    /// Adds one diagnostic (counted only, once its kind has filled its list).
    pub(crate) fn push(&mut self, d: CadastreDiagnostic) {
        tracing::debug!(kind = ?d.kind, consequence = ?d.consequence, fid = d.fid, "cadastre diagnostic");
        let key = (d.layer.clone(), d.kind, d.consequence);
        let limit = match (d.fid, d.kind) {
            (None, _) => usize::MAX,
            (Some(_), DiagnosticKind::HeightDropped) => 0,
            (Some(_), _) => LISTED_PER_KIND,
        };
        let seen = self.seen.entry(key.clone()).or_insert(0);
        if *seen < limit {
            *seen += 1;
            self.listed.push(d);
        } else {
            let at = self.listed.len();
            self.unlisted.entry(key).or_insert((0, d, at)).0 += 1;
        }
    }

    /// Every listed diagnostic, then one line per (layer, kind) whose further diagnostics were only counted:
    /// the count, the first such feature and its detail.
    pub(crate) fn finish(self) -> Vec<CadastreDiagnostic> {
        let mut out = self.listed;
        let mut rest: Vec<(u64, CadastreDiagnostic, usize)> = self.unlisted.into_values().collect();
        // Inserted from the back, so the places of those before stay right; equal places keep reading order.
        rest.sort_by_key(|r| std::cmp::Reverse((r.2, r.1.fid)));
        for (count, first, at) in rest {
            if count == 1 {
                out.insert(at, first);
                continue;
            }
            let listed = if first.kind == DiagnosticKind::HeightDropped { "" } else { "more " };
            let from = first.fid.map_or_else(String::new, |fid| format!(", the first is feature {fid}"));
            let line = CadastreDiagnostic {
                fid: None,
                detail: format!("{count} {listed}features{from}: {}", first.detail),
                ..first
            };
            out.insert(at, line);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    trait WithLayer {
        fn with_layer(self, layer: &str) -> Self;
    }

    impl WithLayer for CadastreDiagnostic {
        fn with_layer(self, layer: &str) -> Self {
            Self { layer: layer.to_owned(), ..self }
        }
    }

    fn diagnostic(kind: DiagnosticKind, consequence: Consequence, fid: u64) -> CadastreDiagnostic {
        let (file, layer, detail) = ("a.gpkg".to_owned(), "lights".to_owned(), format!("problem {fid}"));
        CadastreDiagnostic { kind, consequence, file, layer, fid: Some(fid), field: None, detail }
    }

    #[test]
    fn notes_on_kept_features_are_one_line_and_skips_are_listed_up_to_the_limit() {
        let mut d = Diagnostics::default();
        for fid in 1..=1000 {
            d.push(diagnostic(DiagnosticKind::HeightDropped, Consequence::Kept, fid));
            d.push(diagnostic(DiagnosticKind::NullClass, Consequence::FeatureSkipped, fid));
        }
        d.push(diagnostic(DiagnosticKind::HeightDropped, Consequence::Kept, 7).with_layer("other"));
        let out = d.finish();
        assert_eq!(out.len(), LISTED_PER_KIND + 3, "{out:#?}");
        let height: Vec<_> = out.iter().filter(|d| d.kind == DiagnosticKind::HeightDropped).collect();
        assert_eq!(height.len(), 2);
        assert_eq!(height[0].detail, "1000 features, the first is feature 1: problem 1");
        assert_eq!((height[1].fid, height[1].detail.as_str()), (Some(7), "problem 7"), "one alone stays as it was");
        let last = out.iter().rfind(|d| d.kind == DiagnosticKind::NullClass).unwrap();
        assert_eq!(last.fid, None);
        assert_eq!(last.detail, "980 more features, the first is feature 21: problem 21");
    }
}
