//! One attempt at a tile in the service: read back an output already written, else process the tile and
//! write its output — unless inputs were skipped because the store failed to deliver them, which on any but
//! the last delivery is a retryable error rather than a tile with holes.

use plumbline_geo::tiling::TileId;
use plumbline_runtime::Files;
use plumbline_scheduler::Campaign;

use crate::{TileOutput, TileOutputV1, WorkerConfig, process_tile, tile_key};

/// The skipped-input reason of a file the store failed to deliver (as opposed to `missing` or `decode`).
const UNREAD: &str = "read";

/// Inputs of a tile the store failed to deliver: retry the tile rather than skip them.
#[derive(Debug)]
pub struct UnreadInputs {
    /// The tile.
    pub tile: TileId,
    /// How many inputs were not delivered.
    pub count: usize,
    /// The first one's error.
    pub first: String,
}

impl std::fmt::Display for UnreadInputs {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "tile {}: {} input(s) could not be read from the store (first: {}); retrying the tile rather than \
             skipping them",
            self.tile, self.count, self.first
        )
    }
}

impl std::error::Error for UnreadInputs {}

/// What an attempt produced.
#[derive(Debug)]
pub(crate) struct Attempt {
    /// The tile's output, as written.
    pub output: TileOutputV1,
    /// Whether it was read back from an earlier delivery's write.
    pub resumed: bool,
    /// Seconds spent writing the output (0 when resumed).
    pub write_s: f64,
}

/// Read back, or process and write, the tile's output. `last`: this is the task's last delivery, so inputs
/// the store did not deliver are skipped and listed (as `plumbline run` does) instead of failing the attempt.
pub(crate) async fn attempt(
    files: &Files,
    campaign: &Campaign,
    tile: &TileId,
    config: &WorkerConfig,
    last: bool,
) -> anyhow::Result<Attempt> {
    let url = format!("{}{}", campaign.output, tile_key(tile));
    if let Some(output) = read_back(files, &url, tile).await? {
        return Ok(Attempt { output, resumed: true, write_s: 0.0 });
    }
    tracing::info!("tile inputs being read");
    let output = process_tile(files, campaign, tile, config).await?;
    let unread: Vec<_> = output.skipped.iter().filter(|s| s.reason == UNREAD).collect();
    if let (false, Some(first)) = (last, unread.first()) {
        return Err(UnreadInputs { tile: *tile, count: unread.len(), first: first.detail.clone() }.into());
    }
    let started = std::time::Instant::now();
    let json = serde_json::to_vec_pretty(&TileOutput::V1(output.clone()))?;
    files.write(&url, json).await?;
    Ok(Attempt { output, resumed: false, write_s: started.elapsed().as_secs_f64() })
}

/// The output at `url` when it exists and holds `tile`; one that does not parse or holds another tile is
/// logged and ignored (it is overwritten).
async fn read_back(files: &Files, url: &str, tile: &TileId) -> anyhow::Result<Option<TileOutputV1>> {
    if !files.exists(url).await? {
        return Ok(None);
    }
    let bytes = files.read(url).await?;
    match serde_json::from_slice::<TileOutput>(&bytes).map(TileOutput::into_latest) {
        Ok(done) if done.tile == *tile => Ok(Some(done)),
        Ok(other) => {
            tracing::warn!(file = %url, found = ?other.tile, "tile output holds another tile; reprocessing");
            Ok(None)
        }
        Err(e) => {
            tracing::warn!(file = %url, error = %e, "tile output does not parse; reprocessing");
            Ok(None)
        }
    }
}
