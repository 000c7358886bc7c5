//! CRS transforms through GDAL: reference points checked against `cs2cs` (PROJ on this machine), round trips, convergence.

use plumbline_runtime::{CrsError, CrsTransform, crs_name, is_projected, meridian_convergence};

const WGS84: u32 = 4326;
const UTM32_ETRS89: u32 = 25832;
const SWISS_LV95: u32 = 2056;

/// (lon, lat) → (E, N) references from `echo "LAT LON 0" | cs2cs -f %.6f EPSG:4326 EPSG:<to>`.
const REFERENCES: [(u32, f64, f64, f64, f64); 2] = [
    (UTM32_ETRS89, 9.99, 53.55, 565_590.940_688, 5_933_912.165_416), // Hamburg
    (SWISS_LV95, 7.4386, 46.9511, 2_599_997.532_516, 1_200_001.916_440), // Bern
];

/// Round-trip tolerance in metres. WGS 84 → LV95 crosses a datum (CH1903+) with
/// 2D CRSs on both sides, so each direction takes the height on its own ellipsoid and PROJ itself
/// does not close the loop: `cs2cs EPSG:2056 EPSG:4326` of the Bern reference gives back
/// 46.9511000103 7.4386000074, about 1.2 mm off.
/// 1e-5° is about 1.1 m of latitude and less of longitude, so a tolerance in degrees from this is
/// no looser than in metres.
const DEGREES_PER_METRE: f64 = 1e-5;

fn round_trip_tolerance(epsg: u32) -> f64 {
    if epsg == SWISS_LV95 { 2e-3 } else { 1e-3 }
}

fn transform(from: u32, to: u32) -> CrsTransform {
    CrsTransform::new(from, to).unwrap_or_else(|e| panic!("EPSG:{from} → EPSG:{to}: {e}"))
}

#[test]
fn forward_matches_proj_reference_to_a_millimetre() {
    for (to, lon, lat, east, north) in REFERENCES {
        let (e, n, h) = transform(WGS84, to).transform_point(lon, lat, 12.5).expect("forward");
        assert!((e - east).abs() < 1e-3 && (n - north).abs() < 1e-3, "EPSG:{to}: got {e} {n}, want {east} {north}");
        assert_eq!(h, 12.5, "height is not changed between 2D CRSs");
    }
}

#[test]
fn inverse_matches_proj_reference() {
    // `echo "E N 0" | cs2cs -f %.10f EPSG:<from> EPSG:4326`
    let cases = [
        (UTM32_ETRS89, 565_590.940_688, 5_933_912.165_416, 9.99, 53.55),
        (SWISS_LV95, 2_599_997.532_516, 1_200_001.916_440, 7.438_600_007_4, 46.951_100_010_3),
    ];
    for (from, east, north, lon, lat) in cases {
        let (x, y, _) = transform(from, WGS84).transform_point(east, north, 0.0).expect("inverse");
        assert!((x - lon).abs() < 1e-9 && (y - lat).abs() < 1e-9, "EPSG:{from}: got {x} {y}, want {lon} {lat}");
    }
}

#[test]
fn round_trip_is_below_a_millimetre() {
    for (to, lon, lat, _, _) in REFERENCES {
        let forward = transform(WGS84, to);
        let back = transform(to, WGS84);
        let start = ([lon, lon + 0.01, lon - 0.02], [lat, lat + 0.015, lat - 0.01], [40.0, 520.0, -3.0]);
        let (mut xs, mut ys, mut zs) = start;
        forward.transform(&mut xs, &mut ys, &mut zs).expect("forward");
        let projected = (xs, ys, zs);
        back.transform(&mut xs, &mut ys, &mut zs).expect("back");
        check_close(to, (&xs, &ys, &zs), (&start.0, &start.1, &start.2), round_trip_tolerance(to) * DEGREES_PER_METRE);
        forward.transform(&mut xs, &mut ys, &mut zs).expect("forward again");
        check_close(to, (&xs, &ys, &zs), (&projected.0, &projected.1, &projected.2), round_trip_tolerance(to));
    }
}

fn check_close(epsg: u32, got: (&[f64], &[f64], &[f64]), want: (&[f64], &[f64], &[f64]), horizontal: f64) {
    for i in 0..got.0.len() {
        let (dx, dy, dz) = (got.0[i] - want.0[i], got.1[i] - want.1[i], got.2[i] - want.2[i]);
        assert!(
            dx.abs() < horizontal && dy.abs() < horizontal && dz.abs() < 1e-3,
            "EPSG:{epsg} point {i}: {dx} {dy} {dz}"
        );
    }
}

#[test]
fn unknown_epsg_code_is_named() {
    let err = CrsTransform::new(WGS84, 999_999).expect_err("no such CRS");
    assert!(matches!(err, CrsError::UnknownEpsg { code: 999_999, .. }), "{err}");
    assert!(err.to_string().contains("999999"), "{err}");
    assert!(is_projected(999_999).is_err() && crs_name(999_999).is_err());
}

#[test]
fn mismatched_slices_are_an_error_not_a_panic() {
    let t = transform(WGS84, UTM32_ETRS89);
    let err = t.transform(&mut [1.0, 2.0], &mut [1.0], &mut []).expect_err("length mismatch");
    assert!(matches!(err, CrsError::LengthMismatch { xs: 2, ys: 1, zs: 0 }), "{err}");
    assert!(t.transform(&mut [9.0], &mut [53.0], &mut [1.0, 2.0]).is_err());
    assert!(t.transform(&mut [], &mut [], &mut []).is_ok());
}

#[test]
fn crs_kind_and_name() {
    assert!(is_projected(UTM32_ETRS89).expect("25832"));
    assert!(is_projected(SWISS_LV95).expect("2056"));
    assert!(!is_projected(WGS84).expect("4326"));
    assert_eq!(crs_name(UTM32_ETRS89).expect("25832"), "ETRS89 / UTM zone 32N");
    assert_eq!(crs_name(WGS84).expect("4326"), "WGS 84");
}

/// UTM convergence on the sphere-to-ellipsoid first order: γ ≈ atan(tan(λ − λ0) · sin φ);
/// the neglected ellipsoidal term is below 1e-8 rad within 3° of the central meridian.
fn utm_convergence(lon: f64, lat: f64, central_meridian: f64) -> f64 {
    ((lon - central_meridian).to_radians().tan() * lat.to_radians().sin()).atan()
}

#[test]
fn convergence_matches_the_utm_formula() {
    // (EPSG, central meridian, lon, lat)
    let cases = [
        (UTM32_ETRS89, 9.0, 10.0, 53.5),
        (UTM32_ETRS89, 9.0, 9.99, 53.55),
        (UTM32_ETRS89, 9.0, 7.2, 48.1),
        (UTM32_ETRS89, 9.0, 11.9, 50.0),
        (UTM32_ETRS89, 9.0, 9.0, 51.0),
        (32733, 15.0, 17.0, -30.0), // WGS 84 / UTM zone 33S
    ];
    for (epsg, lon0, lon, lat) in cases {
        let gamma = meridian_convergence(epsg, lon, lat).expect("convergence");
        let expect = utm_convergence(lon, lat, lon0);
        assert!((gamma - expect).abs() < 1e-6, "EPSG:{epsg} at {lon} {lat}: {gamma} vs {expect}");
    }
    assert!(meridian_convergence(UTM32_ETRS89, 10.0, 53.5).expect("east of CM") > 0.0);
}

#[test]
fn convergence_needs_a_projected_crs() {
    let err = meridian_convergence(WGS84, 10.0, 53.5).expect_err("geographic");
    assert!(matches!(err, CrsError::NotProjected { code: WGS84 }), "{err}");
}

/// A compound CRS as LAS deliveries record it (horizontal + vertical, no code of its own) gives its horizontal
/// part's EPSG code, in WKT 1 and WKT 2; a WKT that is no CRS gives none.
#[test]
fn a_compound_crs_gives_its_horizontal_code() {
    use plumbline_runtime::crs::wkt_of_epsg;
    use plumbline_runtime::epsg_of_wkt;
    let (horizontal, vertical) = (wkt_of_epsg(UTM32_ETRS89).unwrap(), wkt_of_epsg(5783).unwrap());
    let wkt1 = format!("COMPD_CS[\"ETRS89 / UTM 32N + DHHN92 height\",{horizontal},{vertical}]");
    assert_eq!(epsg_of_wkt(&wkt1), Some(UTM32_ETRS89));
    // Like Autzen's record (the COPC test file of the poles crate): Oregon GIC Lambert (ft) + NAVD88, here as
    // WKT 2 around a WKT 1 horizontal part (which GDAL cannot parse whole: the part is found all the same).
    let oregon = wkt_of_epsg(2992).unwrap();
    let wkt2 = format!(
        "COMPOUNDCRS[\"NAD83 / Oregon GIC Lambert (ft) + NAVD88 height (ftUS)\",{oregon},VERTCRS[\"NAVD88 height (ftUS)\",VDATUM[\"North American Vertical Datum 1988\"],CS[vertical,1],AXIS[\"gravity-related height (H)\",up,LENGTHUNIT[\"US survey foot\",0.304800609601219]]]]"
    );
    assert_eq!(epsg_of_wkt(&wkt2), Some(2992));
    assert_eq!(epsg_of_wkt("COMPD_CS[\"broken\",PROJCS[\"x\""), None);
    assert_eq!(epsg_of_wkt(&horizontal), Some(UTM32_ETRS89));
}

/// Heights' unit from a WKT's vertical CRS (WKT 1 and 2, alone or in a compound CRS); none without one.
#[test]
fn the_height_unit_comes_from_the_vertical_crs() {
    use plumbline_runtime::crs::wkt_of_epsg;
    use plumbline_runtime::{linear_unit_m, vertical_unit_of_wkt};
    let (horizontal, vertical) = (wkt_of_epsg(UTM32_ETRS89).unwrap(), wkt_of_epsg(5783).unwrap());
    assert_eq!(vertical_unit_of_wkt(&format!("COMPD_CS[\"x\",{horizontal},{vertical}]")), Some(("metre".into(), 1.0)));
    assert_eq!(vertical_unit_of_wkt(&horizontal), None);
    // Autzen's record (the poles crate's COPC test file): NAVD88 height in US survey feet.
    let autzen = "COMPD_CS[\"NAD83 / Oregon GIC Lambert (ft) + NAVD88 height (ftUS)\",PROJCS[\"NAD83 / Oregon GIC Lambert (ft)\",UNIT[\"foot\",0.3048]],VERT_CS[\"NAVD88 height (ftUS)\",VERT_DATUM[\"North American Vertical Datum 1988\",2005],UNIT[\"US survey foot\",0.304800609601219,AUTHORITY[\"EPSG\",\"9003\"]],AXIS[\"Gravity-related height\",UP]]]";
    assert_eq!(vertical_unit_of_wkt(autzen), Some(("US survey foot".into(), 0.304800609601219)));
    let wkt2 = "VERTCRS[\"NAVD88 height (ftUS)\",VDATUM[\"North American Vertical Datum 1988\"],CS[vertical,1],AXIS[\"gravity-related height (H)\",up,LENGTHUNIT[\"US survey foot\",0.304800609601219]]]";
    assert_eq!(vertical_unit_of_wkt(wkt2).map(|u| u.1), Some(0.304800609601219));
    assert_eq!(vertical_unit_of_wkt("VERT_CS[\"broken\",UNIT[\"x\",-1]]"), None);
    assert_eq!(linear_unit_m(UTM32_ETRS89).unwrap(), 1.0);
    assert!((linear_unit_m(2992).unwrap() - 0.3048).abs() < 1e-12);
}
