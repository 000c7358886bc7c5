//! The input files a manifest names, each with its field path, for checks that need the outside world.

use crate::location::Location;
use crate::manifest::{ManifestV1, TrajectorySource};
use crate::problem::FieldPath;

impl ManifestV1 {
    /// Every input object the manifest names (not the prefixes of image folders, not the output), with the
    /// field path that names it, in manifest order.
    pub fn input_locations(&self) -> Vec<(FieldPath, &Location)> {
        let root = FieldPath::root();
        let mut out = Vec::new();
        for (i, t) in self.trajectory.iter().enumerate() {
            trajectory_inputs(&root.field("trajectory").index(i), t, &mut out);
        }
        if let Some(p) = &self.panoramas {
            let path = root.field("panoramas");
            out.push((path.field("index"), &p.index));
            if let Some(mask) = &p.vehicle_mask {
                out.push((path.field("vehicle_mask"), mask));
            }
        }
        for (i, d) in self.depth.iter().enumerate() {
            out.push((root.field("depth").index(i).field("index"), &d.index));
        }
        for (i, l) in self.point_clouds.iter().enumerate() {
            out.push((root.field("point_clouds").index(i).field("url"), &l.url));
        }
        if let Some(aerial) = &self.aerial {
            let path = root.field("aerial");
            if let Some(f) = &aerial.frames {
                out.push((path.field("frames").field("index"), &f.index));
            }
            if let Some(o) = &aerial.orthophoto {
                out.push((path.field("orthophoto").field("image"), &o.image));
                out.push((path.field("orthophoto").field("terrain"), &o.terrain));
            }
        }
        for (i, c) in self.cadastres.iter().enumerate() {
            out.push((root.field("cadastres").index(i).field("url"), &c.url));
        }
        out
    }
}

fn trajectory_inputs<'a>(path: &FieldPath, t: &'a TrajectorySource, out: &mut Vec<(FieldPath, &'a Location)>) {
    out.push((path.field("url"), t.url()));
    if let TrajectorySource::Sbet(s) = t
        && let Some(smrmsg) = &s.smrmsg
    {
        out.push((path.field("smrmsg"), smrmsg));
    }
    if let Some((gnss, imu)) = t.raw_navigation() {
        out.push((path.field("gnss"), gnss));
        out.push((path.field("imu"), imu));
    }
    if let Some(reference) = t.reference() {
        out.push((path.field("reference"), reference));
    }
}

#[cfg(test)]
mod tests {
    use crate::Manifest;

    #[test]
    fn lists_every_input_of_the_full_example_with_its_path() {
        let text = include_str!("../../../schemas/examples/manifest.v1.full.toml");
        let m = Manifest::from_toml_str(text).unwrap().into_latest();
        let paths: Vec<String> = m.input_locations().iter().map(|(p, _)| p.to_string()).collect();
        for expected in ["trajectory[0].url", "panoramas.index", "aerial.frames.index", "cadastres[0].url"] {
            assert!(paths.iter().any(|p| p == expected), "{expected} missing from {paths:?}");
        }
        assert!(!paths.iter().any(|p| p.starts_with("output")));
    }
}
