//! The simulated pole cadastre as a GeoPackage (`cadastre/poles.gpkg`, layers `poles` and `trees`) in
//! ETRS89 geographic coordinates (EPSG 4258, not the campaign's CRS, as agencies often deliver), with the
//! truth table `truth/poles.csv` (campaign CRS).

use anyhow::Context as _;
use plumbline_runtime::CrsTransform;
use plumbline_runtime::gdal_write::{FieldType, FieldValue, PointFeature, PointLayer, geopackage};
use plumbline_synth::cadastre::{self, CadastreErrors, CadastreObject};
use plumbline_synth::world::World;

use super::Sink;

/// CRS of the GeoPackage: ETRS89 latitude/longitude.
pub(crate) const CADASTRE_EPSG: u32 = 4258;

/// Write the GeoPackage and the truth table; returns the manifest's `[[cadastres]]`.
pub(crate) fn write(world: &World, crs: u32, seed: u64, sink: &Sink) -> anyhow::Result<String> {
    write_objects(&cadastre::cadastre(world, &CadastreErrors::typical(), seed), crs, sink)
}

/// Write the GeoPackage of the listed objects (errors as [`CadastreErrors::typical`]) and the truth table of
/// all of them; returns the manifest's `[[cadastres]]`.
pub(crate) fn write_objects(objects: &[CadastreObject], crs: u32, sink: &Sink) -> anyhow::Result<String> {
    let to_file = CrsTransform::new(crs, CADASTRE_EPSG).context("cadastre CRS")?;
    let fields = vec![
        ("id".to_owned(), FieldType::Integer),
        ("class".to_owned(), FieldType::Text),
        ("diameter_m".to_owned(), FieldType::Real),
    ];
    let mut poles = PointLayer { name: "poles".into(), fields: fields.clone(), features: Vec::new() };
    let mut trees = PointLayer { name: "trees".into(), fields, features: Vec::new() };
    for o in objects {
        let Some(feature) = feature(o, &to_file)? else { continue };
        if o.class == "tree" { &mut trees } else { &mut poles }.features.push(feature);
    }
    sink.put("cadastre/poles.gpkg", geopackage(&[poles, trees], CADASTRE_EPSG).context("cadastre GeoPackage")?)?;
    sink.put("truth/poles.csv", cadastre::truth_csv(objects))?;
    Ok(section(&CadastreErrors::typical()))
}

/// The manifest's `[[cadastres]]` of the written GeoPackage.
pub(crate) fn section(errors: &CadastreErrors) -> String {
    format!(
        "[[cadastres]]\nurl = \"cadastre/poles.gpkg\"\nlayers = [\"poles\", \"trees\"]\nclass_attribute = \"class\"\n\
         diameter_attribute = \"diameter_m\"\n\n\
         [cadastres.class_values]\nlight = \"light\"\nsign = \"sign\"\ntraffic_light = \"sign\"\ntree = \"tree\"\n\n\
         [cadastres.accuracy]\npoles = {p:?}\nlights = {p:?}\nsigns = {p:?}\ntrees = {t:?}\n",
        p = errors.pole_sigma_m,
        t = errors.tree_sigma_m
    )
}

/// The listed object as a feature in the file's CRS; `None` when it is not listed.
pub(crate) fn feature(o: &CadastreObject, to_file: &CrsTransform) -> anyhow::Result<Option<PointFeature>> {
    let (Some([e, n]), Some(id)) = (o.listed, o.cadastre_id) else { return Ok(None) };
    let (x, y, _) = to_file.transform_point(e, n, 0.0).with_context(|| format!("cadastre object {id}"))?;
    let values = vec![FieldValue::Integer(id), FieldValue::Text(o.class.to_owned()), FieldValue::Real(o.diameter_m)];
    Ok(Some(PointFeature { x, y, values }))
}
