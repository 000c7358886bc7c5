//! Object prefixes of agencies: where a submitted manifest is stored, and the check that every location it
//! names (inputs, image prefixes, output) stays under its agency's prefix `{store}/agencies/<agency>/`.

use plumbline_campaign::{CampaignId, FieldPath, Location, ManifestV1, resolve};

use super::auth::Agency;

/// A location outside the agency's prefix, or one that cannot be resolved.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct PrefixProblem {
    /// The manifest field (`trajectory[0].url`, `output`, …).
    pub field: String,
    /// What was found.
    pub found: String,
    /// What is expected.
    pub expected: String,
}

/// The store layout of the scheduler: the store root URL (ending in `/`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Layout {
    root: String,
}

impl Layout {
    /// The layout under a store URL (`s3://bucket/prefix`, `file:///dir`, or a local path).
    pub fn new(store: &str) -> Self {
        let mut root = crate::manifest_base(store);
        if !root.ends_with('/') {
            root.push('/');
        }
        Self { root }
    }

    /// The store root, ending in `/`.
    pub fn root(&self) -> &str {
        &self.root
    }

    /// `{root}agencies/<agency>/`.
    pub fn agency_prefix(&self, agency: &Agency) -> String {
        format!("{}agencies/{}/", self.root, agency.as_str())
    }

    /// The agency's prefix when `manifest_url` — read from the bus (a task or a campaign's state), where
    /// anyone able to publish could have written anything — is exactly where the job API stores that agency's
    /// manifest of campaign `id` under this store root: `{root}agencies/<agency>/campaigns/<id>/manifest.(toml|json)`.
    pub fn stored_manifest(&self, manifest_url: &str, agency: &Agency, id: &CampaignId) -> Result<String, String> {
        if [false, true].into_iter().any(|json| self.manifest_url(agency, id, json) == manifest_url) {
            return Ok(self.agency_prefix(agency));
        }
        Err(format!(
            "`{manifest_url}` is not where the job API stores agency {}'s manifest of campaign {} (under {})",
            agency.as_str(),
            id.as_str(),
            self.root
        ))
    }

    /// Where the manifest of a campaign is stored: `{agency prefix}campaigns/<id>/manifest.{toml|json}`.
    pub fn manifest_url(&self, agency: &Agency, id: &CampaignId, json: bool) -> String {
        let ext = if json { "json" } else { "toml" };
        format!("{}campaigns/{}/manifest.{ext}", self.agency_prefix(agency), id.as_str())
    }
}

/// Every location the manifest names (inputs, image prefixes, the output) with its field path.
fn all_locations(manifest: &ManifestV1) -> Vec<(FieldPath, &Location)> {
    let root = FieldPath::root();
    let mut out = manifest.input_locations();
    out.push((root.field("output"), &manifest.output));
    if let Some(p) = &manifest.panoramas {
        out.push((root.field("panoramas").field("images"), &p.images));
    }
    for (i, d) in manifest.depth.iter().enumerate() {
        out.push((root.field("depth").index(i).field("images"), &d.images));
    }
    if let Some(f) = manifest.aerial.as_ref().and_then(|a| a.frames.as_ref()) {
        out.push((root.field("aerial").field("frames").field("images"), &f.images));
    }
    out
}

/// The locations of `manifest` (stored at `manifest_url`) that leave `prefix`, each naming its field.
pub fn check_locations(manifest: &ManifestV1, manifest_url: &str, prefix: &str) -> Vec<PrefixProblem> {
    let expected = format!("a location under the agency's prefix {prefix}");
    let mut problems = Vec::new();
    for (field, location) in all_locations(manifest) {
        let found = match resolve(manifest_url, location.as_str()) {
            Err(e) => Some(e.found()),
            Ok(url) if !url.starts_with(prefix) => Some(format!("{:?} resolves to {url}", location.as_str())),
            Ok(url) if climbs(&url[prefix.len()..]) => {
                Some(format!("{:?} has a \".\" or \"..\" segment after the prefix", location.as_str()))
            }
            Ok(_) => None,
        };
        if let Some(found) = found {
            problems.push(PrefixProblem { field: field.to_string(), found, expected: expected.clone() });
        }
    }
    problems
}

/// Load a campaign whose manifest URL and agency come from the bus, as the worker and the adjuster do: the
/// manifest must be the agency's stored one under the store root the role was started with
/// ([`Layout::stored_manifest`]) and every location it names must still lie under the agency's prefix
/// ([`check_locations`]) — what submission checked, checked again where the reads happen. Either failing is
/// invalid input (the tile or campaign is failed, not retried).
pub async fn load_agency_campaign(
    files: &plumbline_runtime::Files,
    layout: &Layout,
    manifest_url: &str,
    agency: &Agency,
    id: &CampaignId,
) -> plumbline_runtime::Result<plumbline_campaign::Campaign> {
    let prefix = layout.stored_manifest(manifest_url, agency, id).map_err(plumbline_runtime::invalid)?;
    let campaign = crate::load_campaign(files, manifest_url).await?;
    let outside = check_locations(&campaign.manifest, manifest_url, &prefix);
    if let Some(first) = outside.first() {
        return Err(plumbline_runtime::invalid(format!(
            "{manifest_url}: {} location(s) outside the agency's prefix {prefix} (first: {}: {})",
            outside.len(),
            first.field,
            first.found
        )));
    }
    Ok(campaign)
}

/// Why [`stored_output`] found no output prefix.
#[derive(Debug)]
pub enum StoredOutputError {
    /// The store did not answer; a retry may pass.
    Store(String),
    /// The state or the stored manifest was tampered with.
    Tampered(&'static str),
}

/// The stored manifest of `agency`'s campaign (the state's `manifest` only picks `.toml` or `.json`, and
/// must be one of the two) and its output prefix (ending in `/`), resolved from that manifest and checked to
/// lie, like all its locations, under the agency's prefix — derived from agency and id, never read from the
/// state. Where the report, `plan.json` and the tasks' locations come from.
pub async fn stored_output(
    files: &plumbline_runtime::Files,
    layout: &Layout,
    agency: &Agency,
    state: &crate::messages::CampaignState,
) -> Result<(String, String), StoredOutputError> {
    use StoredOutputError::Tampered;
    let manifest_url = [false, true]
        .map(|json| layout.manifest_url(agency, &state.id, json))
        .into_iter()
        .find(|u| *u == state.manifest)
        .ok_or(Tampered("its state names a manifest that is not the agency's stored one"))?;
    let bytes = files.read(&manifest_url).await.map_err(|e| StoredOutputError::Store(format!("{e:#}")))?;
    let manifest = crate::parse_manifest(plumbline_runtime::file_name(&manifest_url), &bytes)
        .map_err(|_| Tampered("its stored manifest no longer parses"))?
        .into_latest();
    if !check_locations(&manifest, &manifest_url, &layout.agency_prefix(agency)).is_empty() {
        return Err(Tampered("its stored manifest names locations outside the agency's prefix"));
    }
    let output = resolve(&crate::manifest_base(&manifest_url), manifest.output.as_str())
        .map_err(|_| Tampered("its output cannot be resolved"))?;
    Ok((manifest_url, format!("{}/", output.trim_end_matches('/'))))
}

impl std::fmt::Display for StoredOutputError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Store(e) => write!(f, "store: {e}"),
            Self::Tampered(what) => f.write_str(what),
        }
    }
}

/// Whether a key has segments that could move it elsewhere once a store normalises it (`..`, `.`, their
/// percent-encodings, or backslashes).
fn climbs(rest: &str) -> bool {
    let lower = rest.to_ascii_lowercase();
    lower.contains("%2e")
        || lower.contains('\\')
        || lower.contains("%5c")
        || rest.split('/').any(|s| s == ".." || s == ".")
}

#[cfg(test)]
mod tests {
    use plumbline_campaign::Manifest;

    use super::*;

    fn manifest(trajectory: &str, output: &str) -> ManifestV1 {
        let text = format!(
            "version = \"1\"\ncrs = 25832\noutput = {output:?}\n[campaign]\nid = \"c1\"\nname = \"c\"\n\
             [[trajectory]]\nformat = \"csv\"\nurl = {trajectory:?}\n"
        );
        Manifest::from_toml_str(&text).unwrap().into_latest()
    }

    fn check(trajectory: &str, output: &str, expect_fields: &[&str]) {
        let layout = Layout::new("s3://bucket/pl");
        let agency = Agency::parse("hamburg").unwrap();
        let url = layout.manifest_url(&agency, &"c1".parse().unwrap(), false);
        assert_eq!(url, "s3://bucket/pl/agencies/hamburg/campaigns/c1/manifest.toml");
        let problems = check_locations(&manifest(trajectory, output), &url, &layout.agency_prefix(&agency));
        let fields: Vec<&str> = problems.iter().map(|p| p.field.as_str()).collect();
        assert_eq!(fields, expect_fields, "{trajectory} {output}: {problems:?}");
    }

    #[test]
    fn locations_must_stay_under_the_agency_prefix() {
        check("nav/dg.csv", "results/", &[]);
        check("s3://bucket/pl/agencies/hamburg/shared/dg.csv", "results/", &[]);
        check("../../../bremen/campaigns/x/dg.csv", "results/", &["trajectory[0].url"]);
        check("nav/dg.csv", "s3://bucket/pl/agencies/bremen/out/", &["output"]);
        check("s3://bucket/pl/agencies/hamburg/../bremen/dg.csv", "results/", &["trajectory[0].url"]);
        check("s3://bucket/pl/agencies/hamburg/%2E%2E/bremen/dg.csv", "results/", &["trajectory[0].url"]);
        check("s3://bucket/pl/agencies/hamburgx/dg.csv", "file:///etc/", &["trajectory[0].url", "output"]);
        check("s3://other/pl/agencies/hamburg/dg.csv", "results/", &["trajectory[0].url"]);
    }

    #[test]
    fn only_the_agencys_stored_manifest_is_taken_from_the_bus() {
        let layout = Layout::new("s3://b/pl");
        let (hamburg, id): (Agency, CampaignId) = (Agency::parse("hamburg").unwrap(), "c1".parse().unwrap());
        let ok = layout.stored_manifest("s3://b/pl/agencies/hamburg/campaigns/c1/manifest.json", &hamburg, &id);
        assert_eq!(ok.unwrap(), "s3://b/pl/agencies/hamburg/");
        for url in [
            "s3://b/pl/agencies/bremen/campaigns/c1/manifest.toml",
            "s3://b/pl/agencies/hamburg/campaigns/c2/manifest.toml",
            "s3://b/pl/agencies/hamburg/campaigns/c1/other.toml",
            "file:///etc/agencies/hamburg/campaigns/c1/manifest.toml",
            "s3://other/pl/agencies/hamburg/campaigns/c1/manifest.toml",
            "s3://b/pl/agencies/hamburg/campaigns/c1/../c1/manifest.toml",
            "s3://b/pl/../agencies/hamburg/campaigns/c1/manifest.toml",
            "s3://b/pl/xagencies/hamburg/campaigns/c1/manifest.toml",
        ] {
            let e = layout.stored_manifest(url, &hamburg, &id).unwrap_err();
            assert!(e.contains("is not where the job API stores agency hamburg's manifest"), "{url}: {e}");
        }
    }

    #[test]
    fn local_stores_get_file_urls() {
        let layout = Layout::new("file:///data/pl/");
        assert_eq!(layout.root(), "file:///data/pl/");
        assert_eq!(layout.agency_prefix(&Agency::parse("bremen").unwrap()), "file:///data/pl/agencies/bremen/");
    }
}
