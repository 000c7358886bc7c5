//! Tile planner: splits a campaign's image sites into tiles of an absolute map grid so that every image
//! is owned by one tile and every MM↔MM pair is processed by exactly one tile that can read both images.
//!
//! The grid is absolute: tile `(col, row)` covers `[col·size, (col+1)·size) × [row·size, (row+1)·size)`
//! in map coordinates (easting, northing), so the tiles of a campaign stay the same when it grows.
//! - An image is **owned** by the cell its position falls in (half-open cells, so borders go east/north).
//! - Consecutive sites in capture order form a **pair** unless they are more than
//!   [`TilingParams::max_pair_distance`] apart (a gap or a new pass). A pair belongs to the tile owning
//!   its first image; when the second image is owned elsewhere it is listed in that tile's **context**.
//! - **fetch** is the bounding box of the tile's owned and context images grown by
//!   [`TilingParams::overlap`]: the area whose aerial images and cadastre features the tile reads.
//!
//! Tiles are sorted row-major (row, then column); the image lists of a tile are in capture order. The
//! planner is pure and deterministic: the same input gives an identical plan. It runs in O(n log n).

use std::cmp::Ordering;
use std::fmt;
use std::str::FromStr;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Default largest distance between consecutive sites that still forms a pair, metres.
pub const DEFAULT_MAX_PAIR_DISTANCE: f64 = 15.0;

/// Largest accepted |coordinate / tile size|: below 2^52 cell indices and cell corners are exact in f64.
const MAX_CELL_INDEX: f64 = 4_503_599_627_370_496.0;

/// Identifier of an image (a panorama and the depth image taken with it) within a campaign.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(transparent)]
pub struct ImageId(pub u64);

impl fmt::Display for ImageId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// Where and when an image was taken: the planner's input, one per image, in capture-time order.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ImageSite {
    /// The image.
    pub id: ImageId,
    /// Capture time, seconds on the campaign's continuous time scale.
    pub time: f64,
    /// Easting of the camera (or vehicle) position, metres in the map frame.
    pub east: f64,
    /// Northing of the camera (or vehicle) position, metres in the map frame.
    pub north: f64,
}

impl ImageSite {
    fn distance_to(&self, other: &ImageSite) -> f64 {
        (other.east - self.east).hypot(other.north - self.north)
    }

    fn point_box(&self) -> BBox {
        BBox::point(self.east, self.north)
    }
}

/// Parameters of the tile planner.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TilingParams {
    /// Edge length of the square grid cells, metres (finite, > 0).
    pub tile_size: f64,
    /// Margin added around a tile's images to form its fetch box, metres (finite, ≥ 0).
    pub overlap: f64,
    /// Consecutive sites farther apart than this do not form a pair, metres (≥ 0; default 15).
    #[serde(default = "default_max_pair_distance")]
    pub max_pair_distance: f64,
}

fn default_max_pair_distance() -> f64 {
    DEFAULT_MAX_PAIR_DISTANCE
}

impl TilingParams {
    /// Parameters with the default [`DEFAULT_MAX_PAIR_DISTANCE`].
    pub fn new(tile_size: f64, overlap: f64) -> Self {
        Self { tile_size, overlap, max_pair_distance: DEFAULT_MAX_PAIR_DISTANCE }
    }

    fn validate(&self) -> Result<(), TilingError> {
        let invalid = |field, value, requirement| Err(TilingError::InvalidParam { field, value, requirement });
        if !(self.tile_size.is_finite() && self.tile_size > 0.0) {
            return invalid("tile_size", self.tile_size, "finite and positive");
        }
        if !(self.overlap.is_finite() && self.overlap >= 0.0) {
            return invalid("overlap", self.overlap, "finite and non-negative");
        }
        if self.max_pair_distance.is_nan() || self.max_pair_distance < 0.0 {
            return invalid("max_pair_distance", self.max_pair_distance, "non-negative");
        }
        Ok(())
    }
}

/// Identifier of a grid cell. Displayed as `c{col}_r{row}` (e.g. `c12_r-3`): only `[A-Za-z0-9_-]`,
/// safe in file names, object keys and NATS subjects. Ordered row-major: by row, then by column.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema)]
pub struct TileId {
    /// Column: the cell spans eastings `[col·size, (col+1)·size)`.
    pub col: i64,
    /// Row: the cell spans northings `[row·size, (row+1)·size)`.
    pub row: i64,
}

impl TileId {
    /// The cell containing a point, or `None` when a coordinate is not finite or too far out for the grid.
    pub fn containing(east: f64, north: f64, tile_size: f64) -> Option<TileId> {
        Some(TileId { col: cell_index(east, tile_size)?, row: cell_index(north, tile_size)? })
    }

    /// The cell's box in map coordinates (the cell itself is half-open on its east and north sides).
    pub fn core(&self, tile_size: f64) -> BBox {
        let (col, row) = (self.col as f64, self.row as f64);
        BBox {
            min_east: col * tile_size,
            min_north: row * tile_size,
            max_east: (col + 1.0) * tile_size,
            max_north: (row + 1.0) * tile_size,
        }
    }
}

/// Index of the half-open cell `[i·size, (i+1)·size)` containing `v`, consistent with [`TileId::core`].
fn cell_index(v: f64, size: f64) -> Option<i64> {
    let q = (v / size).floor();
    if q.is_nan() || q.abs() >= MAX_CELL_INDEX {
        return None;
    }
    // The division may round across a border; settle on the cell whose computed corners contain v.
    let i = if q * size > v {
        q - 1.0
    } else if (q + 1.0) * size <= v {
        q + 1.0
    } else {
        q
    };
    Some(i as i64)
}

impl Ord for TileId {
    fn cmp(&self, other: &Self) -> Ordering {
        (self.row, self.col).cmp(&(other.row, other.col))
    }
}

impl PartialOrd for TileId {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl fmt::Display for TileId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "c{}_r{}", self.col, self.row)
    }
}

/// A string that is not the canonical spelling of a [`TileId`].
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("`{input}` is not a tile id like `c12_r-3`")]
pub struct ParseTileIdError {
    /// The rejected text.
    pub input: String,
}

impl FromStr for TileId {
    type Err = ParseTileIdError;

    /// Parses exactly what `Display` writes (no `+`, no leading zeros), so each tile has one spelling.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let error = || ParseTileIdError { input: s.to_owned() };
        let (col, row) = s.strip_prefix('c').and_then(|rest| rest.split_once("_r")).ok_or_else(error)?;
        let id = TileId { col: col.parse().map_err(|_| error())?, row: row.parse().map_err(|_| error())? };
        if id.to_string() != s {
            return Err(error());
        }
        Ok(id)
    }
}

/// An axis-aligned box in map coordinates, metres. Closed: points on the border are inside.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct BBox {
    /// Smallest easting.
    pub min_east: f64,
    /// Smallest northing.
    pub min_north: f64,
    /// Largest easting.
    pub max_east: f64,
    /// Largest northing.
    pub max_north: f64,
}

impl BBox {
    /// The degenerate box of one point.
    pub fn point(east: f64, north: f64) -> Self {
        Self { min_east: east, min_north: north, max_east: east, max_north: north }
    }

    /// Whether the point lies inside the box or on its border.
    pub fn contains(&self, east: f64, north: f64) -> bool {
        (self.min_east..=self.max_east).contains(&east) && (self.min_north..=self.max_north).contains(&north)
    }

    /// The box grown by `margin ≥ 0` on every side, rounded outward: for every point `p` of `self`,
    /// `p − min ≥ margin` and `max − p ≥ margin` hold when evaluated in f64.
    pub fn expand(&self, margin: f64) -> Self {
        Self {
            min_east: lower_by(self.min_east, margin),
            min_north: lower_by(self.min_north, margin),
            max_east: -lower_by(-self.max_east, margin),
            max_north: -lower_by(-self.max_north, margin),
        }
    }

    /// The smallest box containing both boxes.
    pub fn union(&self, other: &BBox) -> Self {
        Self {
            min_east: self.min_east.min(other.min_east),
            min_north: self.min_north.min(other.min_north),
            max_east: self.max_east.max(other.max_east),
            max_north: self.max_north.max(other.max_north),
        }
    }

    /// Whether the boxes share at least one point (touching borders count).
    pub fn intersects(&self, other: &BBox) -> bool {
        self.min_east <= other.max_east
            && other.min_east <= self.max_east
            && self.min_north <= other.max_north
            && other.min_north <= self.max_north
    }
}

/// `v − margin`, stepped down until `v − result ≥ margin` holds in f64.
fn lower_by(v: f64, margin: f64) -> f64 {
    let mut lowered = v - margin;
    while lowered.is_finite() && v - lowered < margin {
        lowered = lowered.next_down();
    }
    lowered
}

/// The work of one tile: the images it owns, the pairs it registers and the area it reads.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Tile {
    /// The grid cell.
    pub id: TileId,
    /// Images whose position falls in the cell, in capture order. Never empty.
    pub owned: Vec<ImageId>,
    /// Images owned by other tiles that this tile reads as the second image of one of its pairs,
    /// in capture order.
    pub context: Vec<ImageId>,
    /// Consecutive image pairs (first, second) this tile registers, ordered by their first image.
    pub pairs: Vec<(ImageId, ImageId)>,
    /// The cell's box.
    pub core: BBox,
    /// Bounding box of the owned and context images grown by the overlap: the area to fetch.
    pub fetch: BBox,
}

/// The tiles of a campaign, sorted by [`TileId`] (row-major), with an index from image to owning tile.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(try_from = "TilePlanRepr")]
pub struct TilePlan {
    tiles: Vec<Tile>,
    /// (image, index into `tiles`) sorted by image: the lookup behind [`TilePlan::tile_of`].
    #[serde(skip)]
    owners: Vec<(ImageId, usize)>,
}

/// The serialized form of a [`TilePlan`], checked on the way in.
#[derive(Deserialize, JsonSchema)]
#[schemars(rename = "TilePlan")]
struct TilePlanRepr {
    tiles: Vec<Tile>,
}

impl TryFrom<TilePlanRepr> for TilePlan {
    type Error = InvalidPlan;

    fn try_from(repr: TilePlanRepr) -> Result<Self, Self::Error> {
        TilePlan::from_tiles(repr.tiles)
    }
}

/// A list of tiles that cannot form a [`TilePlan`].
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum InvalidPlan {
    /// Tiles are not strictly increasing by id.
    #[error("tile {tile} follows tile {previous}: tiles must be sorted by id, without repeats")]
    TilesNotSorted {
        /// The tile before.
        previous: TileId,
        /// The tile out of order.
        tile: TileId,
    },
    /// An image is owned by two tiles.
    #[error("image {image} is owned by both tile {first} and tile {second}")]
    OwnedTwice {
        /// The image.
        image: ImageId,
        /// The first owner, in tile order.
        first: TileId,
        /// The second owner.
        second: TileId,
    },
}

impl TilePlan {
    /// Assembles a plan from tiles sorted by id whose owned images are disjoint, e.g. a deserialized one.
    pub fn from_tiles(tiles: Vec<Tile>) -> Result<Self, InvalidPlan> {
        if let Some(w) = tiles.windows(2).find(|w| w[0].id >= w[1].id) {
            return Err(InvalidPlan::TilesNotSorted { previous: w[0].id, tile: w[1].id });
        }
        let mut owners: Vec<(ImageId, usize)> =
            tiles.iter().enumerate().flat_map(|(t, tile)| tile.owned.iter().map(move |&id| (id, t))).collect();
        owners.sort_unstable();
        if let Some(w) = owners.windows(2).find(|w| w[0].0 == w[1].0) {
            let (first, second) = (tiles[w[0].1].id, tiles[w[1].1].id);
            return Err(InvalidPlan::OwnedTwice { image: w[0].0, first, second });
        }
        Ok(Self { tiles, owners })
    }

    /// The tiles, sorted by id.
    pub fn tiles(&self) -> &[Tile] {
        &self.tiles
    }

    /// The tiles, sorted by id, consuming the plan.
    pub fn into_tiles(self) -> Vec<Tile> {
        self.tiles
    }

    /// The tile with this id, if it has work. O(log tiles).
    pub fn tile(&self, id: &TileId) -> Option<&Tile> {
        let t = self.tiles.binary_search_by(|tile| tile.id.cmp(id)).ok()?;
        self.tiles.get(t)
    }

    /// The tile owning an image, if the image is in the plan. O(log images).
    pub fn tile_of(&self, image: ImageId) -> Option<&TileId> {
        let k = self.owners.binary_search_by_key(&image, |&(id, _)| id).ok()?;
        let &(_, t) = self.owners.get(k)?;
        self.tiles.get(t).map(|tile| &tile.id)
    }

    /// Counts for logs and reports.
    pub fn summary(&self) -> PlanSummary {
        let mut owned: Vec<usize> = self.tiles.iter().map(|t| t.owned.len()).collect();
        owned.sort_unstable();
        PlanSummary {
            tiles: self.tiles.len(),
            images: self.owners.len(),
            context_images: self.tiles.iter().map(|t| t.context.len()).sum(),
            pairs: self.tiles.iter().map(|t| t.pairs.len()).sum(),
            owned_per_tile: CountStats::of_sorted(&owned),
        }
    }
}

/// Size of a plan.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct PlanSummary {
    /// Number of tiles.
    pub tiles: usize,
    /// Number of images (each owned by one tile).
    pub images: usize,
    /// Number of context entries over all tiles (images read by a tile that does not own them).
    pub context_images: usize,
    /// Number of pairs over all tiles.
    pub pairs: usize,
    /// Owned images per tile; `None` for an empty plan.
    pub owned_per_tile: Option<CountStats>,
}

impl fmt::Display for PlanSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} tiles, {} images, {} pairs, {} context images",
            self.tiles, self.images, self.pairs, self.context_images
        )?;
        if let Some(s) = &self.owned_per_tile {
            write!(f, "; images per tile min {} / median {} / max {}", s.min, s.median, s.max)?;
        }
        Ok(())
    }
}

/// Minimum, median and maximum of a list of counts.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct CountStats {
    /// Smallest count.
    pub min: usize,
    /// Median count (mean of the two middle counts when their number is even).
    pub median: f64,
    /// Largest count.
    pub max: usize,
}

impl CountStats {
    fn of_sorted(counts: &[usize]) -> Option<Self> {
        let (&min, &max) = (counts.first()?, counts.last()?);
        let mid = counts.len() / 2;
        let median = match counts.len() % 2 {
            1 => counts[mid] as f64,
            _ => (counts[mid - 1] + counts[mid]) as f64 / 2.0,
        };
        Some(Self { min, median, max })
    }
}

/// A defect of the planner's input; site errors name the site (0-based, input order) and the field.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TilingError {
    /// A parameter is out of its range.
    #[error("parameter `{field}` must be {requirement}, got {value}")]
    InvalidParam {
        /// The parameter.
        field: &'static str,
        /// Its value.
        value: f64,
        /// What it must be.
        requirement: &'static str,
    },
    /// A time or coordinate is NaN or infinite.
    #[error("site {index} (image {id}): field `{field}` is not finite ({value})")]
    NotFinite {
        /// The site.
        index: usize,
        /// Its image.
        id: ImageId,
        /// `time`, `east` or `north`.
        field: &'static str,
        /// The value.
        value: f64,
    },
    /// A coordinate is so large against the tile size that its cell index cannot be represented.
    #[error("site {index} (image {id}): field `{field}` ({value}) is outside the grid of {tile_size} m tiles")]
    OutsideGrid {
        /// The site.
        index: usize,
        /// Its image.
        id: ImageId,
        /// `east` or `north`.
        field: &'static str,
        /// The value.
        value: f64,
        /// The tile size.
        tile_size: f64,
    },
    /// Sites are not in capture-time order.
    #[error("site {index} (image {id}): field `time` ({time}) is earlier than the previous site's ({previous})")]
    TimeNotOrdered {
        /// The site.
        index: usize,
        /// Its image.
        id: ImageId,
        /// Its time.
        time: f64,
        /// The previous site's time.
        previous: f64,
    },
    /// Two sites carry the same image id.
    #[error("site {index}: field `id` ({id}) repeats site {first}")]
    DuplicateImageId {
        /// The later site.
        index: usize,
        /// The repeated id.
        id: ImageId,
        /// The earlier site with that id.
        first: usize,
    },
}

/// Plans the tiles of a campaign from its image sites, given in capture-time order.
pub fn plan(sites: &[ImageSite], params: &TilingParams) -> Result<TilePlan, TilingError> {
    params.validate()?;
    let cells = locate_sites(sites, params.tile_size)?;
    let by_id = ids_checked_unique(sites)?;
    let (tile_ids, tile_of_site) = group_by_cell(&cells);
    let mut drafts: Vec<Draft> = tile_ids.iter().map(|_| Draft::default()).collect();
    for (site, &t) in sites.iter().zip(&tile_of_site) {
        drafts[t].add_owned(site);
    }
    assign_pairs(sites, &tile_of_site, params.max_pair_distance, &mut drafts);
    let tiles = tile_ids.into_iter().zip(drafts).map(|(id, draft)| draft.finish(id, params)).collect();
    let owners = by_id.into_iter().map(|(id, site)| (id, tile_of_site[site])).collect();
    Ok(TilePlan { tiles, owners })
}

/// Checks every site's fields and time order, and returns the cell of each site.
fn locate_sites(sites: &[ImageSite], tile_size: f64) -> Result<Vec<TileId>, TilingError> {
    let mut cells = Vec::with_capacity(sites.len());
    let mut previous = f64::NEG_INFINITY;
    for (index, site) in sites.iter().enumerate() {
        check_finite(index, site)?;
        if site.time < previous {
            return Err(TilingError::TimeNotOrdered { index, id: site.id, time: site.time, previous });
        }
        previous = site.time;
        cells.push(locate(index, site, tile_size)?);
    }
    Ok(cells)
}

fn check_finite(index: usize, site: &ImageSite) -> Result<(), TilingError> {
    for (field, value) in [("time", site.time), ("east", site.east), ("north", site.north)] {
        if !value.is_finite() {
            return Err(TilingError::NotFinite { index, id: site.id, field, value });
        }
    }
    Ok(())
}

fn locate(index: usize, site: &ImageSite, tile_size: f64) -> Result<TileId, TilingError> {
    let axis = |field, value| {
        cell_index(value, tile_size).ok_or(TilingError::OutsideGrid { index, id: site.id, field, value, tile_size })
    };
    Ok(TileId { col: axis("east", site.east)?, row: axis("north", site.north)? })
}

/// (image id, site index) sorted by id, or the first site (in input order) repeating an earlier id.
fn ids_checked_unique(sites: &[ImageSite]) -> Result<Vec<(ImageId, usize)>, TilingError> {
    let mut by_id: Vec<(ImageId, usize)> = sites.iter().enumerate().map(|(index, site)| (site.id, index)).collect();
    by_id.sort_unstable();
    let repeat = by_id.windows(2).filter(|w| w[0].0 == w[1].0).min_by_key(|w| w[1].1);
    if let Some(w) = repeat {
        return Err(TilingError::DuplicateImageId { index: w[1].1, id: w[1].0, first: w[0].1 });
    }
    Ok(by_id)
}

/// The distinct cells, sorted, and for each site the index of its cell in that list.
fn group_by_cell(cells: &[TileId]) -> (Vec<TileId>, Vec<usize>) {
    let mut order: Vec<usize> = (0..cells.len()).collect();
    order.sort_unstable_by_key(|&site| cells[site]);
    let mut tile_ids: Vec<TileId> = Vec::new();
    let mut tile_of_site = vec![0; cells.len()];
    for site in order {
        if tile_ids.last() != Some(&cells[site]) {
            tile_ids.push(cells[site]);
        }
        tile_of_site[site] = tile_ids.len() - 1;
    }
    (tile_ids, tile_of_site)
}

/// Gives each close-enough consecutive pair to the tile owning its first image.
fn assign_pairs(sites: &[ImageSite], tile_of_site: &[usize], max_distance: f64, drafts: &mut [Draft]) {
    for (first, w) in sites.windows(2).enumerate() {
        let (a, b) = (&w[0], &w[1]);
        if a.distance_to(b) > max_distance {
            continue;
        }
        let (owner, other) = (tile_of_site[first], tile_of_site[first + 1]);
        drafts[owner].pairs.push((a.id, b.id));
        if other != owner {
            drafts[owner].add_context(b);
        }
    }
}

/// A tile being assembled.
#[derive(Default)]
struct Draft {
    owned: Vec<ImageId>,
    context: Vec<ImageId>,
    pairs: Vec<(ImageId, ImageId)>,
    extent: Option<BBox>,
}

impl Draft {
    fn add_owned(&mut self, site: &ImageSite) {
        self.owned.push(site.id);
        self.include(site);
    }

    fn add_context(&mut self, site: &ImageSite) {
        self.context.push(site.id);
        self.include(site);
    }

    fn include(&mut self, site: &ImageSite) {
        let point = site.point_box();
        self.extent = Some(self.extent.map_or(point, |extent| extent.union(&point)));
    }

    fn finish(self, id: TileId, params: &TilingParams) -> Tile {
        let core = id.core(params.tile_size);
        // Every draft owns at least one site, so the extent is set; fall back to the core regardless.
        let fetch = self.extent.unwrap_or(core).expand(params.overlap);
        Tile { id, owned: self.owned, context: self.context, pairs: self.pairs, core, fetch }
    }
}
