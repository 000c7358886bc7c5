//! Validation of a parsed manifest: every rule that serde's types cannot express, checked in one
//! pass that reports all problems at once, and `ValidManifest`, the proof that it passed.

use std::collections::BTreeMap;
use std::ops::Deref;

use crate::epsg::EpsgKind;
use crate::manifest::{Manifest, ManifestV1};
use crate::problem::{Checker, FieldPath, Problems};

/// A manifest that passed [`Manifest::validate`], in the newest version's types.
#[derive(Debug, Clone, PartialEq)]
pub struct ValidManifest(ManifestV1);

impl ValidManifest {
    /// The validated manifest.
    pub fn manifest(&self) -> &ManifestV1 {
        &self.0
    }

    /// The validated manifest, by value.
    pub fn into_inner(self) -> ManifestV1 {
        self.0
    }
}

impl Deref for ValidManifest {
    type Target = ManifestV1;

    fn deref(&self) -> &ManifestV1 {
        &self.0
    }
}

impl Manifest {
    /// Checks every rule and returns all problems at once, each naming its field's path.
    ///
    /// EPSG codes are checked only for range and against well-known geographic codes; whether a
    /// code exists and is projected is for the service layer (GDAL) to confirm.
    pub fn validate(&self) -> Result<ValidManifest, Problems> {
        let mut checker = Checker::default();
        match self {
            Self::V1(v1) => v1.check(&mut checker),
        }
        checker.finish().map(|()| ValidManifest(self.clone().into_latest()))
    }
}

impl ManifestV1 {
    fn check(&self, c: &mut Checker) {
        let root = FieldPath::root();
        c.not_blank(&root.field("campaign").field("name"), &self.campaign.name);
        if let Some(agency) = &self.campaign.agency {
            c.not_blank(&root.field("campaign").field("agency"), agency);
        }
        self.check_crs(&root.field("crs"), c);
        c.location(&root.field("output"), &self.output);
        self.check_trajectory(&root.field("trajectory"), c);
        self.check_sensors(&root, c);
        if let Some(aerial) = &self.aerial {
            aerial.check(&root.field("aerial"), c);
        }
        self.check_cadastres(&root.field("cadastres"), c);
        self.tiling.check(&root.field("tiling"), c);
        self.parameters.check(&root.field("parameters"), c);
    }

    fn check_crs(&self, at: &FieldPath, c: &mut Checker) {
        let expected = "the EPSG code of a projected CRS, e.g. 25832 (ETRS89 / UTM 32N)";
        let crs = self.crs;
        match crs.kind() {
            EpsgKind::OutOfRange => c.report(at, format!("{crs} is not an EPSG CRS code (1024..=32767)"), expected),
            EpsgKind::Geographic(name) => c.report(at, format!("{crs} ({name}) is geographic"), expected),
            EpsgKind::Geocentric(name) => c.report(at, format!("{crs} ({name}) is geocentric"), expected),
            EpsgKind::PlausiblyProjected => {}
        }
    }

    fn check_trajectory(&self, at: &FieldPath, c: &mut Checker) {
        if self.trajectory.is_empty() {
            c.report(at, "no trajectory is given", "at least one [[trajectory]] source");
        }
        for (i, source) in self.trajectory.iter().enumerate() {
            source.check(&at.index(i), c);
            if let Some(first) = self.trajectory[..i].iter().position(|s| s.url() == source.url()) {
                let found = format!("{} is already trajectory[{first}]", source.url());
                c.report(&at.index(i).field("url"), found, "each trajectory file once");
            }
        }
    }

    fn check_sensors(&self, root: &FieldPath, c: &mut Checker) {
        if let Some(panoramas) = &self.panoramas {
            panoramas.check(&root.field("panoramas"), c);
        }
        for (i, camera) in self.depth.iter().enumerate() {
            camera.check(&root.field("depth").index(i), c);
        }
        for (i, cloud) in self.point_clouds.iter().enumerate() {
            cloud.check(&root.field("point_clouds").index(i), c);
        }
    }

    fn check_cadastres(&self, at: &FieldPath, c: &mut Checker) {
        let mut seen: BTreeMap<(&str, &str), usize> = BTreeMap::new();
        for (i, cadastre) in self.cadastres.iter().enumerate() {
            cadastre.check(&at.index(i), c);
            for (k, layer) in cadastre.layers.iter().enumerate() {
                match seen.get(&(cadastre.url.as_str(), layer.as_str())) {
                    Some(&first) if first != i => {
                        let found =
                            format!("layer {layer:?} of {} is already read by cadastres[{first}]", cadastre.url);
                        c.report(&at.index(i).field("layers").index(k), found, "each GeoPackage layer once");
                    }
                    _ => {
                        seen.entry((cadastre.url.as_str(), layer.as_str())).or_insert(i);
                    }
                }
            }
        }
    }
}
