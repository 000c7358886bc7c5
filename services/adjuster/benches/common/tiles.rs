//! The tile outputs of a finished run, read for the benches that re-adjust it.

use plumbline_worker::{TileOutput, TileOutputV1};

/// Every `*.json` tile output in `dir`, sorted by file name.
pub fn read_tiles(dir: &str) -> Vec<TileOutputV1> {
    let mut paths: Vec<_> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).collect();
    paths.sort();
    paths
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .map(|p| serde_json::from_slice::<TileOutput>(&std::fs::read(p).unwrap()).unwrap().into_latest())
        .collect()
}
