//! The one latitude/longitude validator: every position on the wire (mission points,
//! observations, telemetry, avoidance requests) is checked here, with the same ranges the
//! OpenAPI schema declares ([`LAT_RANGE_DEG`], [`LON_RANGE_DEG`]).

use crate::error::FieldError;

/// Valid latitudes, degrees (inclusive).
pub const LAT_RANGE_DEG: (f64, f64) = (-90.0, 90.0);
/// Valid longitudes, degrees (inclusive).
pub const LON_RANGE_DEG: (f64, f64) = (-180.0, 180.0);

/// Checks a WGS84 position in degrees; pushes one error per bad coordinate, at `lat_ptr`
/// and `lon_ptr` (the JSON pointers of the two fields as the client named them). Returns
/// whether both are valid. NaN and infinities are invalid.
pub fn check_lat_lon(
    errs: &mut Vec<FieldError>,
    lat_ptr: &str,
    lon_ptr: &str,
    lat_deg: f64,
    lon_deg: f64,
) -> bool {
    let mut ok = true;
    if !(lat_deg.is_finite() && (LAT_RANGE_DEG.0..=LAT_RANGE_DEG.1).contains(&lat_deg)) {
        errs.push(FieldError::new(
            lat_ptr,
            format!("latitude {lat_deg} is not in [-90, 90]"),
        ));
        ok = false;
    }
    if !(lon_deg.is_finite() && (LON_RANGE_DEG.0..=LON_RANGE_DEG.1).contains(&lon_deg)) {
        errs.push(FieldError::new(
            lon_ptr,
            format!("longitude {lon_deg} is not in [-180, 180]"),
        ));
        ok = false;
    }
    ok
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn bounds_are_inclusive_and_each_bad_field_is_named() {
        let mut errs = vec![];
        assert!(check_lat_lon(&mut errs, "/a", "/b", -90.0, 180.0));
        assert!(check_lat_lon(&mut errs, "/a", "/b", 90.0, -180.0));
        assert!(errs.is_empty());
        assert!(!check_lat_lon(
            &mut errs,
            "/p/lat",
            "/p/lon",
            90.5,
            f64::NAN
        ));
        let ptrs: Vec<_> = errs.iter().map(|e| e.pointer.as_str()).collect();
        assert_eq!(ptrs, ["/p/lat", "/p/lon"]);
    }

    proptest! {
        #[test]
        fn valid_exactly_when_inside_the_ranges(lat in -200.0..200.0f64, lon in -400.0..400.0f64) {
            let mut errs = vec![];
            let ok = check_lat_lon(&mut errs, "/lat", "/lon", lat, lon);
            let expect = lat.abs() <= 90.0 && lon.abs() <= 180.0;
            prop_assert_eq!(ok, expect);
            prop_assert_eq!(errs.len(), usize::from(lat.abs() > 90.0) + usize::from(lon.abs() > 180.0));
        }
    }
}
