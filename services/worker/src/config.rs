//! The worker's settings: the workflow configurations with the manifest's `[parameters]` applied, and how
//! many files a tile reads at once.

use plumbline_campaign::ManifestV1;
use plumbline_poles::PoleConfig;
use plumbline_registration::PipelineConfig;

/// Files a tile reads at once by default.
pub const DEFAULT_CONCURRENCY: usize = 8;

/// Everything [`crate::process_tile`] needs besides the campaign.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorkerConfig {
    /// Registration of the panoramas with each other and with the aerial reference (Jende et al. 2017).
    pub registration: PipelineConfig,
    /// Pole detection and cadastre matching (Meyer et al. 2023).
    pub poles: PoleConfig,
    /// Files read at once (panoramas, depth images, aerial frames); at least 1.
    pub concurrency: usize,
}

impl Default for WorkerConfig {
    fn default() -> Self {
        Self { registration: PipelineConfig::default(), poles: PoleConfig::default(), concurrency: DEFAULT_CONCURRENCY }
    }
}

impl WorkerConfig {
    /// The defaults with the manifest's `parameters.registration` and `parameters.poles` applied.
    ///
    /// `aerial_gsd_m` (and the block's `gsd_m`) has no counterpart here: the registration takes each aerial
    /// image's ground sampling distance from its orientation (frames) or geotransform (orthophoto).
    pub fn from_manifest(manifest: &ManifestV1) -> Self {
        let mut config = Self::default();
        let r = &manifest.parameters.registration;
        let registration = &mut config.registration;
        registration.mm.gsd = r.mm_gsd_m; // Jende et al. 2017 §3.2
        registration.aerial.min_images = r.min_aerial_images as usize; // Jende et al. 2017 §3.7
        if !r.single_aerial_rays {
            registration.aerial.single_ray_sigma_m = None;
        }
        registration.aerial.min_correspondences = r.min_correspondences as usize; // Jende et al. 2017 §3.8
        // A patch with fewer triangulated points cannot reach the correspondences an image needs.
        registration.min_mm_points = r.min_correspondences as usize;
        config.poles.detect.max_range_m = manifest.parameters.poles.max_range_m; // Meyer et al. 2023 §3.1.2
        config
    }
}

#[cfg(test)]
mod tests {
    use plumbline_campaign::Manifest;

    use super::*;

    fn manifest(parameters: &str) -> ManifestV1 {
        let text = format!(
            "version = \"1\"\ncrs = 25832\noutput = \"out/\"\n[campaign]\nid = \"c\"\nname = \"c\"\n\
             [[trajectory]]\nformat = \"sbet\"\nurl = \"nav/dg.sbet\"\n{parameters}"
        );
        Manifest::from_toml_str(&text).unwrap().into_latest()
    }

    #[test]
    fn manifest_parameters_reach_the_workflow_configs() {
        let m = manifest(
            "[parameters.registration]\nmm_gsd_m = 0.05\nmin_aerial_images = 3\nmin_correspondences = 15\n\
             [parameters.poles]\nmax_range_m = 7.5\n",
        );
        let c = WorkerConfig::from_manifest(&m);
        assert_eq!(c.registration.mm.gsd, 0.05);
        assert_eq!(c.registration.aerial.min_images, 3);
        assert_eq!(c.registration.aerial.min_correspondences, 15);
        assert_eq!(c.registration.min_mm_points, 15);
        assert_eq!(c.poles.detect.max_range_m, 7.5);
        // Everything else keeps the workflow defaults.
        let d = WorkerConfig::default();
        assert_eq!(c.registration.aerial.template_half, d.registration.aerial.template_half);
        assert_eq!(c.poles.matching, d.poles.matching);
        assert_eq!(c.concurrency, DEFAULT_CONCURRENCY);
    }

    #[test]
    fn manifest_defaults_are_the_papers_values() {
        let c = WorkerConfig::from_manifest(&manifest(""));
        assert_eq!(c.registration.mm.gsd, 0.03); // Jende et al. 2017 §3.2: 3 cm
        assert_eq!(c.registration.aerial.min_images, 2); // §3.7: two aerial images
        assert_eq!(c.registration.aerial.min_correspondences, 10); // §3.8: ten correspondences
        assert_eq!(c.poles.detect.max_range_m, 10.0);
    }
}
