//! The v1 manifest of a simulated campaign: the navigation section always, the sensor sections for what was
//! written; parsed and validated before it is stored.

use std::fmt::Write as _;

use plumbline_campaign::Manifest;
use plumbline_synth::sensors::Mount;

use crate::exit::invalid;

/// The optional sections, as TOML text, each produced by the module that wrote its files.
#[derive(Debug, Default)]
pub(crate) struct Sections {
    /// `[panoramas]`.
    pub panoramas: Option<String>,
    /// `[[depth]]`.
    pub depth: Option<String>,
    /// `[[point_clouds]]`.
    pub point_clouds: Option<String>,
    /// `[[cadastres]]`.
    pub cadastre: Option<String>,
    /// `[aerial]`.
    pub aerial: Option<String>,
}

/// `[{table}.mount]` of a camera.
pub(crate) fn mount(table: &str, m: &Mount) -> String {
    let [x, y, z] = m.lever_arm_m;
    let [r, p, h] = m.boresight_deg;
    format!("\n[{table}.mount]\nlever_arm_m = [{x:?}, {y:?}, {z:?}]\nboresight_deg = [{r:?}, {p:?}, {h:?}]\n")
}

/// The manifest text, checked before it is written.
pub(crate) fn manifest(id: &str, crs: u32, sections: &Sections) -> anyhow::Result<String> {
    finish(header(id, crs, "gnss = \"nav/gnss.csv\"\nimu = \"nav/imu.csv\"\n"), sections)
}

/// Everything up to the trajectory's reference; `raw` names the raw sensor files.
fn header(id: &str, crs: u32, raw: &str) -> String {
    format!(
        "# A synthetic campaign written by `plumbline simulate`; paths are relative to this file.\n\
         version = \"1\"\n\
         crs = {crs}\n\
         output = \"results/\"\n\n\
         [campaign]\n\
         id = \"{id}\"\n\
         name = \"Synthetic campaign {id}\"\n\n\
         [[trajectory]]\n\
         format = \"sbet\"\n\
         url = \"nav/dg.sbet\"\n\
         smrmsg = \"nav/dg.smrmsg\"\n\
         {raw}\
         reference = \"truth/trajectory.csv\"\n"
    )
}

/// The header followed by the sections, parsed and validated.
fn finish(mut text: String, sections: &Sections) -> anyhow::Result<String> {
    for section in [&sections.panoramas, &sections.depth, &sections.point_clouds, &sections.aerial, &sections.cadastre]
        .into_iter()
        .flatten()
    {
        let _ = write!(text, "\n{section}");
    }
    let parsed = Manifest::from_toml_str(&text).map_err(|e| invalid(format!("generated manifest: {e}")))?;
    if let Err(problems) = parsed.validate() {
        let list: Vec<String> = problems.iter().map(ToString::to_string).collect();
        return Err(invalid(format!("generated manifest: {}", list.join("; "))));
    }
    Ok(text)
}
