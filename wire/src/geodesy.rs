//! WGS84 <-> local East-North-Up conversion, through ECEF (`map_3d`).
//!
//! The mission's local frame has its origin at the home position (or the first fly-zone
//! vertex) at 0 m MSL. Horizontal ENU coordinates are what the planner and predictor see;
//! altitudes stay metres MSL (the `up` component, which includes the earth's curvature
//! drop, is not used for altitude).

use map_3d::Ellipsoid;

/// A local tangent-plane frame anchored at a WGS84 origin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalFrame {
    lat0_rad: f64,
    lon0_rad: f64,
}

impl LocalFrame {
    /// A frame whose origin is at (`lat_deg`, `lon_deg`), 0 m MSL.
    pub fn new(lat_deg: f64, lon_deg: f64) -> Self {
        Self {
            lat0_rad: lat_deg.to_radians(),
            lon0_rad: lon_deg.to_radians(),
        }
    }

    /// The origin as (latitude, longitude) in degrees.
    pub fn origin_deg(&self) -> (f64, f64) {
        (self.lat0_rad.to_degrees(), self.lon0_rad.to_degrees())
    }

    /// WGS84 degrees -> ENU metres `[east, north]`.
    pub fn to_enu(&self, lat_deg: f64, lon_deg: f64) -> [f64; 2] {
        let (e, n, _u) = map_3d::geodetic2enu(
            lat_deg.to_radians(),
            lon_deg.to_radians(),
            0.0,
            self.lat0_rad,
            self.lon0_rad,
            0.0,
            Ellipsoid::WGS84,
        );
        [e, n]
    }

    /// ENU metres -> WGS84 degrees `(lat, lon)`: the point on the ellipsoid below
    /// `[east, north]`.
    pub fn to_geodetic(&self, p_m: [f64; 2]) -> (f64, f64) {
        // The ENU plane is tangent at the origin: a point at `up = 0` far from the origin
        // sits above the ellipsoid. Lift it back onto the ellipsoid by the curvature drop
        // so that to_geodetic(to_enu(x)) == x.
        let r = 6_371_000.0_f64;
        let d2 = p_m[0] * p_m[0] + p_m[1] * p_m[1];
        let drop_m = d2 / (2.0 * r);
        let (lat, lon, _alt) = map_3d::enu2geodetic(
            p_m[0],
            p_m[1],
            -drop_m,
            self.lat0_rad,
            self.lon0_rad,
            0.0,
            Ellipsoid::WGS84,
        );
        (lat.to_degrees(), lon.to_degrees())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn one_arc_minute_of_latitude_matches_the_wgs84_meridian_arc() {
        // At 38 deg N a minute of latitude is 1849.9439 m on WGS84 (Karney's geodesic,
        // geographiclib `Geodesic.WGS84.Inverse(38, -76, 38 + 1/60, -76)`).
        let f = LocalFrame::new(38.0, -76.0);
        let [e, n] = f.to_enu(38.0 + 1.0 / 60.0, -76.0);
        assert!(e.abs() < 0.001, "{e}");
        assert!((n - 1849.9439).abs() < 0.01, "{n}");
    }

    #[test]
    fn webster_field_distance_matches_a_geodesic() {
        // Two Webster Field fly-zone vertices; the geodesic distance between them is
        // 596.204 m (geographiclib). The tangent plane is exact to millimetres at this range.
        let f = LocalFrame::new(38.1462694444444, -76.4281638888889);
        let [e, n] = f.to_enu(38.151625, -76.4286833333333);
        let d = (e * e + n * n).sqrt();
        assert!((d - 596.204).abs() < 0.01, "{d}");
    }

    proptest! {
        #[test]
        fn enu_round_trips_within_a_millimetre(
            lat0 in -60.0..60.0f64, lon0 in -179.0..179.0f64,
            de in -3000.0..3000.0f64, dn in -3000.0..3000.0f64,
        ) {
            let f = LocalFrame::new(lat0, lon0);
            let (lat, lon) = f.to_geodetic([de, dn]);
            let [e, n] = f.to_enu(lat, lon);
            prop_assert!((e - de).abs() < 1e-3 && (n - dn).abs() < 1e-3, "{e} {n} vs {de} {dn}");
        }
    }
}
