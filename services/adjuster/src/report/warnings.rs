//! Named inputs that yielded no control. An input the manifest names but that gave the adjustment nothing —
//! a cadastre whose layers were all skipped, an orthophoto no panorama matched, point clouds — must never
//! look like a quiet success: each becomes an [`InputWarning`] in the report, the run's summary and its
//! exit message (`plumbline run --strict` then exits non-zero).

use plumbline_campaign::{ManifestV1, Stage};
use plumbline_report::InputWarning;

use crate::merge::Merged;

/// One warning per named input that yielded no control in `merged`.
pub fn input_warnings(manifest: &ManifestV1, merged: &Merged) -> Vec<InputWarning> {
    let mut out = Vec::new();
    let updates_of_layer =
        |layer: u32| merged.observations.poles.iter().filter(|p| layer_of(&p.cadastre_id) == Some(layer)).count();
    let observes_poles = !manifest.depth.is_empty() || !manifest.point_clouds.is_empty();
    let mut first_layer = 0u32;
    for (i, cadastre) in manifest.cadastres.iter().enumerate() {
        let layers = u32::try_from(cadastre.layers.len()).unwrap_or(u32::MAX);
        let updates: usize = (first_layer..first_layer.saturating_add(layers)).map(updates_of_layer).sum();
        first_layer = first_layer.saturating_add(layers);
        if updates > 0 {
            continue;
        }
        let location = cadastre.url.as_str();
        let file = location.rsplit('/').next().unwrap_or(location);
        let skipped = merged.skipped.iter().filter(|s| s.stage == Stage::Cadastre && s.item.contains(file)).count();
        let why = if !observes_poles {
            "no depth camera or point cloud in the manifest observes poles".to_owned()
        } else if skipped > 0 {
            format!("{skipped} of its items were skipped (listed under skipped items: layers, features or the file)")
        } else {
            "no pole it lists was detected and matched near the drive (is its CRS or `epsg` right?)".to_owned()
        };
        out.push(InputWarning {
            input: format!("cadastres[{i}]"),
            location: location.to_owned(),
            message: format!("0 pole updates from {} layer(s): {why}", cadastre.layers.len()),
        });
    }
    if let Some(aerial) = &manifest.aerial {
        let matched = merged.images.iter().filter(|i| i.matched()).count();
        if matched == 0 {
            let (input, location) = match (&aerial.orthophoto, &aerial.frames) {
                (Some(o), _) => ("aerial.orthophoto", o.image.as_str()),
                (None, Some(f)) => ("aerial.frames", f.index.as_str()),
                (None, None) => ("aerial", ""),
            };
            let skipped = merged.skipped.iter().filter(|s| s.stage == Stage::Registration).count();
            out.push(InputWarning {
                input: input.to_owned(),
                location: location.to_owned(),
                message: format!(
                    "no panorama of {} was matched with the aerial reference (0 aerial tie points; {skipped} \
                     registration items skipped — does it cover the drive, in the campaign CRS?)",
                    merged.images.len()
                ),
            });
        }
    }
    for (i, camera) in manifest.depth.iter().enumerate() {
        if merged.observations.poles.is_empty() && !manifest.cadastres.is_empty() {
            out.push(InputWarning {
                input: format!("depth[{i}]"),
                location: camera.index.as_str().to_owned(),
                message: "0 pole updates from the depth images (see the pole frames and skipped items)".to_owned(),
            });
        }
    }
    for (i, cloud) in manifest.point_clouds.iter().enumerate() {
        let prefix = plumbline_poles::cloud::frame_prefix(i);
        let frames: Vec<_> = merged.pole_frames.iter().filter(|f| f.frame.starts_with(&prefix)).collect();
        let updates = frames.iter().flat_map(|f| &f.matches).filter(|m| m.no_update.is_none()).count();
        if updates > 0 {
            continue;
        }
        let stems: usize = frames.iter().map(|f| f.detections.len()).sum();
        let skipped =
            merged.skipped.iter().filter(|s| s.stage == Stage::Poles && s.item.contains(cloud.url.as_str())).count();
        let why = if manifest.cadastres.is_empty() {
            "no cadastre to match its stems against".to_owned()
        } else if frames.is_empty() && skipped > 0 {
            format!("{skipped} of its items were skipped (listed under skipped items)")
        } else if frames.is_empty() {
            "no time slice of it was searched (do its GPS times match the trajectory's? is it a cloud of this \
             drive?)"
                .to_owned()
        } else {
            format!("{stems} stems found in {} time slices, none matched to the cadastre", frames.len())
        };
        out.push(InputWarning {
            input: format!("point_clouds[{i}]"),
            location: cloud.url.as_str().to_owned(),
            message: format!("0 pole updates from the point cloud: {why}"),
        });
    }
    out
}

/// The global layer index of a cadastre id `layer:fid[:part]`.
fn layer_of(cadastre_id: &str) -> Option<u32> {
    cadastre_id.split(':').next()?.parse().ok()
}

#[cfg(test)]
mod tests {
    use plumbline_adjustment::PoleUpdate;
    use plumbline_campaign::Manifest;
    use plumbline_geo::tiling::TileId;

    use super::*;
    use crate::merge::ImageOutcome;

    const MANIFEST: &str = r#"
version = "1"
crs = 25832
output = "out/"
point_clouds = ["lidar/a.laz"]
[campaign]
id = "c"
name = "c"
[[trajectory]]
format = "sbet"
url = "dg.sbet"
[panoramas]
index = "p/index.csv"
images = "p/"
[panoramas.mount]
lever_arm_m = [0.0, 0.0, 0.0]
boresight_deg = [0.0, 0.0, 0.0]
[[depth]]
index = "d/index.csv"
images = "d/"
[depth.intrinsics]
fx = 1.0
fy = 1.0
cx = 1.0
cy = 1.0
width_px = 2
height_px = 2
depth_scale_m = 0.001
min_range_m = 0.4
max_range_m = 10.0
[depth.mount]
lever_arm_m = [0.0, 0.0, 0.0]
boresight_deg = [0.0, 0.0, 0.0]
[aerial.orthophoto]
image = "o.tif"
terrain = "t.tif"
[[cadastres]]
url = "a.gpkg"
layers = ["lights", "signs"]
class = "light"
[[cadastres]]
url = "b.gpkg"
layers = ["trees"]
class = "tree"
"#;

    fn update(id: &str) -> PoleUpdate {
        PoleUpdate {
            cadastre_id: id.into(),
            time: 0.0,
            cadastre: [0.0; 2],
            observed: [0.0; 2],
            sigma_camera: 0.1,
            sigma_pole: 0.1,
        }
    }

    fn image(matched: bool) -> ImageOutcome {
        let discarded = (!matched).then(|| ("aerial.too_few".to_owned(), "few".to_owned()));
        ImageOutcome { image: "p1".into(), time: 0.0, tile: TileId { col: 0, row: 0 }, discarded }
    }

    #[test]
    fn every_named_input_without_control_is_warned_about_once() {
        let manifest = Manifest::from_toml_str(MANIFEST).unwrap().into_latest();
        // Layer 1 is the first cadastre's second layer, layer 2 the second cadastre's only layer.
        let mut merged = Merged::default();
        merged.observations.poles = vec![update("1:17")];
        merged.images = vec![image(false), image(false)];
        let inputs: Vec<String> = input_warnings(&manifest, &merged).into_iter().map(|w| w.input).collect();
        assert_eq!(inputs, ["cadastres[1]", "aerial.orthophoto", "point_clouds[0]"]);
        // Both cadastres and the aerial reference contribute: only the point clouds are left.
        merged.observations.poles.push(update("2:3:1"));
        merged.images.push(image(true));
        let left = input_warnings(&manifest, &merged);
        assert_eq!(left.len(), 1);
        assert!(left[0].message.contains("no time slice"), "{left:?}");
        // No pole update at all: every cadastre and the depth camera.
        merged.observations.poles.clear();
        let inputs: Vec<String> = input_warnings(&manifest, &merged).into_iter().map(|w| w.input).collect();
        assert_eq!(inputs, ["cadastres[0]", "cadastres[1]", "depth[0]", "point_clouds[0]"]);
    }

    #[test]
    fn the_layer_of_a_cadastre_id() {
        assert_eq!(layer_of("3:17"), Some(3));
        assert_eq!(layer_of("0:5:2"), Some(0));
        assert_eq!(layer_of("x"), None);
    }
}
