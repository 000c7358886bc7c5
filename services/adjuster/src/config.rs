//! The adjuster's settings: the adjustment's from the manifest's `parameters.adjustment`, the consistency
//! check's, and whether standstills are detected and constrained.

use plumbline_adjustment::{AdjustmentConfig, Snooping};
use plumbline_campaign::ManifestV1;
use plumbline_campaign::manifest::RobustLoss;
use plumbline_navigation::{ConsistencyConfig, chi2_critical};

/// Everything the adjuster needs to know besides the data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdjusterConfig {
    /// The global adjustment (its `standstill` field is set from [`AdjusterConfig::standstills`] when solving).
    pub adjustment: AdjustmentConfig,
    /// The consistency check of image motions against the DG trajectory.
    pub consistency: ConsistencyConfig,
    /// Detect standstills in the DG trajectory and constrain the corrected pose to stay put over them.
    pub standstills: bool,
    /// Adjust with the image-derived motions as relative observations (they flag DG jumps either way).
    pub image_motions: bool,
}

impl Default for AdjusterConfig {
    fn default() -> Self {
        Self {
            adjustment: AdjustmentConfig::default(),
            consistency: ConsistencyConfig::default(),
            standstills: true,
            image_motions: true,
        }
    }
}

impl AdjusterConfig {
    /// The settings a manifest asks for: `loss`/`huber_k` → the Huber threshold (none for plain least
    /// squares), `snooping_alpha` → the w-test's two-sided critical value, `max_iterations`, `image_motions`;
    /// the rest default.
    pub fn from_manifest(manifest: &ManifestV1) -> Self {
        let p = &manifest.parameters.adjustment;
        let mut config = Self::default();
        config.adjustment.huber = match p.loss {
            RobustLoss::None => None,
            RobustLoss::Huber => Some(p.huber_k),
        };
        let snooping = config.adjustment.snooping.unwrap_or_default();
        config.adjustment.snooping = Some(Snooping { critical_value: critical_value(p.snooping_alpha), ..snooping });
        config.adjustment.max_iterations = p.max_iterations as usize;
        config.image_motions = p.image_motions;
        config
    }

    /// The adjustment's settings with standstill detection switched on or off as configured.
    pub fn adjustment(&self) -> AdjustmentConfig {
        let standstill = self.standstills.then(|| self.adjustment.standstill.unwrap_or_default());
        AdjustmentConfig { standstill, ..self.adjustment }
    }
}

/// The two-sided critical value of the normalised residual at significance `alpha`: |w| > z_{1−α/2}, from
/// w² ~ χ²₁ (Baarda's w-test).
pub fn critical_value(alpha: f64) -> f64 {
    chi2_critical(1.0, alpha).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn alpha_maps_to_the_normal_quantile() {
        // z_{1−α/2}: 3.2905 for α = 0.1 %, 1.9600 for 5 %.
        assert!((critical_value(0.001) - 3.2905).abs() < 1e-3, "{}", critical_value(0.001));
        assert!((critical_value(0.05) - 1.9600).abs() < 1e-3, "{}", critical_value(0.05));
    }

    fn manifest(parameters: &str) -> ManifestV1 {
        let toml = format!(
            "version = \"1\"\ncrs = 25832\noutput = \"out/\"\n[campaign]\nid = \"c\"\nname = \"c\"\n\
             [[trajectory]]\nformat = \"csv\"\nurl = \"dg.csv\"\n{parameters}"
        );
        plumbline_campaign::Manifest::from_toml_str(&toml).unwrap().into_latest()
    }

    #[test]
    fn manifest_parameters_reach_the_adjustment() {
        let plain = "[parameters.adjustment]\nloss = \"none\"\nsnooping_alpha = 0.05\nmax_iterations = 7\n";
        let c = AdjusterConfig::from_manifest(&manifest(plain)).adjustment;
        assert_eq!((c.huber, c.max_iterations), (None, 7));
        assert!((c.snooping.unwrap().critical_value - 1.96).abs() < 1e-3);
        let c = AdjusterConfig::from_manifest(&manifest("[parameters.adjustment]\nhuber_k = 2.5\n")).adjustment;
        assert_eq!((c.huber, c.max_iterations), (Some(2.5), 20));
        assert!((c.snooping.unwrap().critical_value - 3.29).abs() < 1e-2);
        assert!(AdjusterConfig::from_manifest(&manifest("")).image_motions);
        let off = "[parameters.adjustment]\nimage_motions = false\n";
        assert!(!AdjusterConfig::from_manifest(&manifest(off)).image_motions);
    }

    #[test]
    fn standstills_switch_the_adjustments_detection() {
        let on = AdjusterConfig::default();
        assert!(on.adjustment().standstill.is_some());
        let off = AdjusterConfig { standstills: false, ..on };
        assert!(off.adjustment().standstill.is_none());
    }
}
