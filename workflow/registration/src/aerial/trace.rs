//! What step 7 (Jende et al. 2017 §3.8) did with every corner in one aerial image — the NCC peak of each candidate,
//! the RANSAC inliers, the correspondences left after the cross-image consistency — for diagnosing losses
//! against ground truth (the registration bench). Not part of the wire result.

/// One corner's search in one aerial image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Attempt {
    /// The corner's position in [`super::MmPatch::points`].
    pub slot: usize,
    /// Where the initial (or DG) transformation put it, full-image pixel.
    pub predicted: [f64; 2],
    /// The best NCC placement inside the search window, full-image pixel (None: on the window's border).
    pub peak: Option<[f64; 2]>,
    /// Its NCC coefficient.
    pub score: Option<f64>,
    /// The best coefficient at least two pixels from the peak (the ambiguity of the search).
    pub second: Option<f64>,
    /// Förstner roundness of the template at the aerial GSD (0: an edge, 1: an isotropic corner).
    pub roundness: f64,
    /// The refined position when the match was accepted (score ≥ `min_ncc`), full-image pixel.
    pub matched: Option<[f64; 2]>,
}

/// The trace of one aerial image.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ImageTrace {
    /// Frame (or orthophoto) id.
    pub frame: String,
    /// Search radius used, pixels (the DG-bounded search uses the plausibility bound).
    pub radius: usize,
    /// Every candidate corner (template valid, transfer inside the window).
    pub attempts: Vec<Attempt>,
    /// Slots kept by the per-image RANSAC (empty when it failed).
    pub ransac: Vec<usize>,
    /// Slots kept after the cross-image consistency and the per-image minimum.
    pub kept: Vec<usize>,
}

impl ImageTrace {
    /// The trace of the searches `attempts` (window pixels; the window's place in the image is `origin`).
    pub(crate) fn of(
        frame: &str,
        radius: usize,
        attempts: &[super::correspond::SlotAttempt],
        origin: [f64; 2],
    ) -> Self {
        let full = |p: [f64; 2]| [p[0] + origin[0], p[1] + origin[1]];
        let attempts = attempts
            .iter()
            .map(|a| Attempt {
                slot: a.slot,
                predicted: full(a.transfer),
                peak: a.peak.map(|p| full(p.0)),
                score: a.peak.map(|p| p.1),
                second: a.peak.map(|p| p.2),
                roundness: a.roundness,
                matched: a.matched.map(full),
            })
            .collect();
        Self { frame: frame.to_owned(), radius, attempts, ..Self::default() }
    }
}
