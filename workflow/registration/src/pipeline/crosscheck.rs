//! The cross-panorama consistency check of Jende et al. 2017 §3.9: "the same object coordinate derived from aerial
//! images may be returned more than once. This is used for outlier removal as well." Every matched panorama
//! measures the DG error at its place (its aerial offset: aerial − MM position in its DG ortho-image).
//! Between two matched panoramas the DG error changes by what the DG trajectory moved minus what the vehicle
//! truly moved, and the image-derived motion (Cazzaniga et al. 2007 §4.1, `crate::mm::image_motion`) measures the
//! latter without the DG trajectory. So two matched panoramas joined by a chain of image motions must agree:
//!     o_k − o_i = Σ (image displacement − DG displacement)     over the chain's links,
//! and a registration that is wrong as a whole (all its points on the wrong dash, consistent across aerial
//! frames, invisible inside the patch) stands out against its partners.
//!
//! Pure function over plain data: offsets and links in tile time order (link k joins panoramas k and k + 1).
//! Without image motion no comparison is made: the DG trajectory's relative motion is not trusted (in canyons
//! multipath makes it jump), and a jump is exactly what the offsets must be allowed to follow.

use plumbline_navigation::ImageMotion;

/// Settings of the check.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CrossCheckConfig {
    /// Run the check (off: every matched panorama stays matched, no verdicts are written).
    pub enabled: bool,
    /// Most links of image motion a chain between two partners may have: each adds its σ, and with more
    /// of them one wrong motion is more likely to sit in the chain. 12 links (60 m at 5 m spacing) keep the
    /// chain's σ_h near √12 · √2 · 1 cm ≈ 5 cm at the motions' typical 1 cm per axis.
    pub max_links: usize,
    /// Partners agree when the residual's length is at most `z` σ_h plus `floor_m`, with σ_h² = Σ (σ_e² +
    /// σ_n²) over both offsets and the chain's links. For isotropic Gaussian errors (σ per axis, σ_h² = 2σ²)
    /// |r| > z σ_h means χ²₂ > 2z², probability e^(−z²): 1.2e-4 at z = 3.
    pub z: f64,
    /// Metres added to the bound for errors the σ do not carry, per pair: each panorama's offset shares
    /// its aerial frames' AT error (3 cm in position, 3″ ≈ 2 cm on the ground in the synthetic block, as in
    /// Jende et al. 2017) and a matching bias its points share (up to a quarter of a 12 cm aerial pixel, 3 cm),
    /// ≈ 5 cm summed, and the DG heading error times the lever from the body origin to its points (0.05° ×
    /// 7.5 m ≈ 7 mm); two panoramas, ≈ 0.12 m — one aerial pixel. Half the 0.24 m "correct" bound of the
    /// accuracy report, so a registration off by a wrong dash (≥ 1.5 m) cannot hide in it. Road slope needs
    /// no term: with a terrain model the patch follows it (`mm::ortho`), so an offset is the DG's horizontal
    /// error alone; without one, the level plane turns slope into an offset that neighbouring panoramas
    /// share almost all of.
    pub floor_m: f64,
    /// Prior σ of one aerial point's horizontal position per axis (metres), for a panorama's offset when
    /// its few points' spread says little: half a 12 cm aerial pixel, what NCC + LSM on road markings
    /// achieves (a point within 2 pixels counts as correct).
    pub point_std_m: f64,
    /// Metres the DG displacement between two consecutive panoramas may be off without a jump (its drift
    /// over a few seconds). A link whose image motion agrees with the DG displacement within z σ plus this
    /// is corroborated by the DG and is never blamed: for it to be wrong, the DG would have to have jumped
    /// by exactly the motion's error (the KAZE matches are searched within `MmConfig::guide_radius` of the
    /// DG prediction, so that takes a periodic pattern whose period equals the jump). Comparisons that
    /// disagree across a corroborated link blame panoramas.
    pub dg_motion_m: f64,
}

impl Default for CrossCheckConfig {
    fn default() -> Self {
        Self { enabled: true, max_links: 12, z: 3.0, floor_m: 0.12, point_std_m: 0.06, dg_motion_m: 0.10 }
    }
}

/// A matched panorama's aerial offset with its σ (east, north; metres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Offset {
    /// aerial − MM position, east and north.
    pub value: [f64; 2],
    /// σ east and north.
    pub std: [f64; 2],
}

/// What the image motion says about the change of the offset from one panorama to the next in time order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Link {
    /// o_next − o_this expected: image displacement − DG displacement, east and north, metres.
    pub change: [f64; 2],
    /// Its σ east and north (the motion's).
    pub std: [f64; 2],
}

impl Link {
    /// The link of an image motion from the earlier panorama to the later one (`motion` in time order, as
    /// `crate::mm::image_motion` reports it) and the two DG body-origin positions (east, north) it joins:
    /// the DG error changes by (DG − image) displacement, the offset (minus the DG error) by the opposite.
    pub fn of(motion: &ImageMotion, dg_earlier: [f64; 2], dg_later: [f64; 2]) -> Self {
        // Cazzaniga et al. 2007 §4.1: Δe = (DG displacement) − (image displacement); the offset is −e.
        let change = [0, 1].map(|c| motion.displacement[c] - (dg_later[c] - dg_earlier[c]));
        Self { change, std: [motion.std[0], motion.std[1]] }
    }

    /// True when the image motion agrees with the DG displacement (`change` ≈ 0 within z σ +
    /// [`CrossCheckConfig::dg_motion_m`]): two sensors measured the same motion.
    pub fn corroborated(&self, config: &CrossCheckConfig) -> bool {
        self.change[0].hypot(self.change[1]) <= config.z * horizontal(self.std).sqrt() + config.dg_motion_m
    }
}

/// Two matched panoramas compared through a chain.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Comparison {
    /// The partner (index in the input).
    pub partner: usize,
    /// |(o_partner − o_this) − Σ link changes|, metres.
    pub residual_m: f64,
    /// z · σ + floor, metres.
    pub tolerance_m: f64,
}

impl Comparison {
    /// True when the two offsets agree.
    pub fn agrees(&self) -> bool {
        self.residual_m <= self.tolerance_m
    }
}

/// The check's verdict on one panorama.
#[derive(Clone, Debug, PartialEq)]
pub enum Verdict {
    /// No offset: not matched, nothing to check.
    Unchecked,
    /// Matched, but no partner within reach: kept, unverified.
    Unverified,
    /// Kept; its comparisons with the partners that were not flagged.
    Kept(Vec<Comparison>),
    /// Its offset is not to be trusted; its comparisons with the partners still counted when it was flagged.
    Flagged(Vec<Comparison>),
}

/// What the check decided.
#[derive(Clone, Debug, PartialEq)]
pub struct Checked {
    /// Per panorama, in the input's order.
    pub verdicts: Vec<Verdict>,
    /// Links whose image motions the offsets contradict (index k: between panoramas k and k + 1), dropped
    /// like missing motions: every comparison across them disagreed by one residual. All links between the
    /// same two matched panoramas carry the same comparisons, so all of them are listed: one is wrong.
    pub broken_links: Vec<usize>,
}

/// Check the `offsets` (per panorama in time order, `None` = not matched) against each other through the
/// `links` (link k between panoramas k and k + 1, `None` = no image motion; one fewer than the panoramas).
/// A panorama is flagged when it disagrees with two partners that agree with each other, or with more
/// partners than agree with it; the worst first, and a flagged one no longer counts for or against others.
/// Two partners that disagree with nobody else to ask are both flagged. A wrong image motion makes every
/// comparison across it disagree by the same residual: such a link (between groups of at least
/// three panoramas (`MIN_GROUP`)) is dropped instead, like a missing motion, when that explains more
/// disagreements than flagging the worst panorama would, net of its agreements — unless the DG displacement
/// corroborates the motion ([`Link::corroborated`]): then the panoramas on one side are wrong alike (a run of
/// consecutive panoramas registered on the same wrong dash), and the majority decides which.
pub fn check(offsets: &[Option<Offset>], links: &[Option<Link>], config: &CrossCheckConfig) -> Checked {
    let mut links = links.to_vec();
    let mut active: Vec<bool> = offsets.iter().map(Option::is_some).collect();
    let mut verdicts: Vec<Verdict> = vec![Verdict::Unchecked; offsets.len()];
    let mut broken_links = Vec::new();
    loop {
        let pairs = comparisons(offsets, &links, config);
        let panorama = worst(&pairs, &active);
        match (panorama, worst_link(&pairs, &active, &links, config)) {
            (_, Some((k, score))) if panorama.is_none_or(|(_, p)| score > p.0) => {
                broken_links.extend(drop_stretch(&mut links, &active, k));
            }
            (Some((worst, _)), _) => {
                let partners = of(&pairs, &active, worst);
                let isolated = partners.len() == 1 && of(&pairs, &active, partners[0].partner).len() == 1;
                let flagged = if isolated { vec![worst, partners[0].partner] } else { vec![worst] };
                for &p in &flagged {
                    verdicts[p] = Verdict::Flagged(of(&pairs, &active, p));
                }
                flagged.iter().for_each(|&p| active[p] = false);
            }
            (None, _) => {
                for (i, verdict) in verdicts.iter_mut().enumerate().filter(|(i, _)| active[*i]) {
                    let partners = of(&pairs, &active, i);
                    *verdict = if partners.is_empty() { Verdict::Unverified } else { Verdict::Kept(partners) };
                }
                return Checked { verdicts, broken_links };
            }
        }
    }
}

/// Drop link `k` and every other link between the same two active panoramas (they carry the same
/// comparisons, so the check cannot tell which of them is wrong); the indices dropped.
fn drop_stretch(links: &mut [Option<Link>], active: &[bool], k: usize) -> Vec<usize> {
    let first = (0..=k).rev().find(|&i| active[i]).unwrap_or(0);
    let last = (k + 1..active.len()).find(|&i| active[i]).unwrap_or(active.len());
    let stretch = links.iter_mut().enumerate().take(last).skip(first);
    stretch.filter_map(|(j, link)| link.take().map(|_| j)).collect()
}

/// A comparison between panoramas `a` < `b`.
#[derive(Clone, Copy, Debug)]
struct Pair {
    a: usize,
    b: usize,
    /// (o_b − o_a) − Σ link changes, east and north.
    residual: [f64; 2],
    residual_m: f64,
    tolerance_m: f64,
}

/// Every pair of matched panoramas joined by an unbroken chain of at most `max_links` links.
fn comparisons(offsets: &[Option<Offset>], links: &[Option<Link>], config: &CrossCheckConfig) -> Vec<Pair> {
    let mut pairs = Vec::new();
    for (a, oa) in offsets.iter().enumerate().filter_map(|(a, o)| o.map(|o| (a, o))) {
        let (mut sum, mut variance) = ([0.0; 2], 0.0);
        // Panorama b is reached through link b − 1.
        let ahead = offsets.iter().enumerate().skip(a + 1).zip(links.iter().skip(a)).take(config.max_links);
        for ((b, ob), link) in ahead {
            let Some(link) = link else { break };
            (0..2).for_each(|c| sum[c] += link.change[c]);
            variance += horizontal(link.std);
            let Some(ob) = ob else { continue };
            // Jende et al. 2017 §3.9: both offsets measure the DG error; the chain carries one to the other.
            let r = [0, 1].map(|c| ob.value[c] - oa.value[c] - sum[c]);
            let sigma = (horizontal(oa.std) + horizontal(ob.std) + variance).sqrt();
            let tolerance_m = config.z * sigma + config.floor_m;
            pairs.push(Pair { a, b, residual: r, residual_m: r[0].hypot(r[1]), tolerance_m });
        }
    }
    pairs
}

/// σ_e² + σ_n².
fn horizontal(std: [f64; 2]) -> f64 {
    std[0] * std[0] + std[1] * std[1]
}

/// The comparisons of panorama `p` with the active partners.
fn of(pairs: &[Pair], active: &[bool], p: usize) -> Vec<Comparison> {
    pairs
        .iter()
        .filter_map(|q| match (q.a == p, q.b == p) {
            (true, _) => Some(q.b),
            (_, true) => Some(q.a),
            _ => None,
        })
        .filter(|&partner| active[partner] && partner != p)
        .map(|partner| {
            let q = pairs.iter().find(|q| (q.a, q.b) == (p.min(partner), p.max(partner)));
            let (residual_m, tolerance_m) = q.map_or((f64::NAN, f64::NAN), |q| (q.residual_m, q.tolerance_m));
            Comparison { partner, residual_m, tolerance_m }
        })
        .collect()
}

/// True when panoramas `a` and `b` are partners that agree.
fn agree(pairs: &[Pair], a: usize, b: usize) -> bool {
    pairs.iter().any(|q| (q.a, q.b) == (a.min(b), a.max(b)) && q.residual_m <= q.tolerance_m)
}

/// The active panorama to flag next, if any: among those that disagree with two partners agreeing with
/// each other or with more partners than agree, the one with most disagreements net of agreements, then
/// the largest residual relative to its bound.
fn worst(pairs: &[Pair], active: &[bool]) -> Option<(usize, (i64, f64))> {
    let mut best: Option<(usize, (i64, f64))> = None;
    for p in (0..active.len()).filter(|&p| active[p]) {
        let partners = of(pairs, active, p);
        let (agreeing, disagreeing): (Vec<&Comparison>, Vec<&Comparison>) = partners.iter().partition(|c| c.agrees());
        let outvoted = disagreeing
            .iter()
            .enumerate()
            .any(|(k, x)| disagreeing[k + 1..].iter().any(|y| agree(pairs, x.partner, y.partner)));
        if !(outvoted || disagreeing.len() > agreeing.len()) {
            continue;
        }
        let ratio = disagreeing.iter().map(|c| c.residual_m / c.tolerance_m).fold(0.0, f64::max);
        let score = (disagreeing.len() as i64 - agreeing.len() as i64, ratio);
        if best.is_none_or(|(_, b)| score.0 > b.0 || (score.0 == b.0 && score.1 > b.1)) {
            best = Some((p, score));
        }
    }
    best
}

/// Fewest panoramas on each side of a link for the link to be blamed rather than them: consecutive
/// panoramas see the same repainted dash, so two of them can be wrong by the same offset and agree.
const MIN_GROUP: usize = 3;

/// The link to drop next, if any, with the comparisons across it: among the links across which most
/// comparisons of active panoramas disagree, all by one shared residual within their bounds (what one wrong
/// motion does; a wrong panorama does not: its partners on its own side agree across the link), with at
/// least [`MIN_GROUP`] panoramas compared on each side, the one with most. Most, not every: a motion off by
/// about the bound leaves some comparisons just inside it (a tiled tiny canyon run flagged seven right
/// panoramas beside a DG jump whose motion was 0.35 m off against bounds of 0.31–0.34 m).
fn worst_link(
    pairs: &[Pair],
    active: &[bool],
    links: &[Option<Link>],
    config: &CrossCheckConfig,
) -> Option<(usize, i64)> {
    let mut best: Option<(usize, i64)> = None;
    let blamable = |k: &usize| links[*k].is_some_and(|l| !l.corroborated(config));
    for k in (0..links.len()).filter(blamable) {
        let across: Vec<&Pair> = pairs.iter().filter(|q| active[q.a] && active[q.b] && q.a <= k && k < q.b).collect();
        let n = across.len() as i64;
        let side = |end: fn(&Pair) -> usize| {
            let mut members: Vec<usize> = across.iter().map(|q| end(q)).collect();
            members.sort_unstable();
            members.dedup();
            members.len()
        };
        let groups = side(|q| q.a) >= MIN_GROUP && side(|q| q.b) >= MIN_GROUP;
        let agreeing = across.iter().filter(|q| q.residual_m <= q.tolerance_m).count() as i64;
        if !groups || 2 * agreeing >= n || best.is_some_and(|(_, b)| n <= b) {
            continue;
        }
        let shared = [0, 1].map(|c| median(across.iter().map(|q| q.residual[c]).collect()));
        let one_error =
            across.iter().all(|q| (q.residual[0] - shared[0]).hypot(q.residual[1] - shared[1]) <= q.tolerance_m);
        if one_error {
            best = Some((k, n));
        }
    }
    best
}

/// The median of a list (`plumbline_geo::metrics::median`); NaN when empty.
fn median(mut v: Vec<f64>) -> f64 {
    plumbline_geo::metrics::median(&mut v).unwrap_or(f64::NAN)
}

#[cfg(test)]
mod tests;
