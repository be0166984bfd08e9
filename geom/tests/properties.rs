//! Property tests of the geometry invariants, with `geo` as an independent oracle for the
//! polygon predicates.

use approx::assert_relative_eq;
use geo::Covers;
use geom::{
    Point, Polygon, closest_t_on_segment, cross, dist, dist_point_segment,
    distance_to_polygon_boundary, dot, lerp, norm, perp, point_in_polygon, segment_inside_polygon,
    segments_intersect, sub, unit, wrap_pi,
};
use proptest::prelude::*;

mod common;
use common::zones;

fn geo_polygon(ring: &[Point]) -> geo::Polygon<f64> {
    geo::Polygon::new(
        geo::LineString::from(ring.iter().map(|p| (p[0], p[1])).collect::<Vec<_>>()),
        vec![],
    )
}

/// Grid points from -1 to 11 in steps of 1/2: many land on vertices and edges.
fn grid_point() -> impl Strategy<Value = Point> {
    (-2i32..=22, -2i32..=22).prop_map(|(x, y)| [f64::from(x) * 0.5, f64::from(y) * 0.5])
}

/// A grid point, or a vertex or quarter point of one of zone `z`'s edges (exact in binary):
/// legs between boundary points are where the boundary rule matters.
fn grid_or_boundary_point(z: usize) -> impl Strategy<Value = Point> {
    let ring = zones()[z].clone();
    let n = ring.len();
    let on_boundary = (0..n, 0..4u8)
        .prop_map(move |(k, q)| lerp(ring[k], ring[(k + 1) % n], f64::from(q) * 0.25));
    prop_oneof![grid_point(), on_boundary]
}

fn any_point() -> impl Strategy<Value = Point> {
    (-20.0..20.0f64, -20.0..20.0f64).prop_map(|(x, y)| [x, y])
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// A point is inside or on the boundary exactly when `geo` says the polygon covers it.
    #[test]
    fn point_in_polygon_agrees_with_geo_covers(z in 0usize..3, p in grid_point()) {
        let ring = &zones()[z];
        let expected = geo_polygon(ring).covers(&geo::Point::new(p[0], p[1]));
        prop_assert_eq!(point_in_polygon(p, ring), expected);
        prop_assert_eq!(Polygon::new(ring).contains(p), expected);
    }

    /// Off the grid too, away from the boundary.
    #[test]
    fn contains_agrees_with_geo_off_the_grid(z in 0usize..3, x in -2.0..12.0f64, y in -2.0..12.0f64) {
        let ring = &zones()[z];
        let expected = geo_polygon(ring).covers(&geo::Point::new(x, y));
        prop_assert_eq!(Polygon::new(ring).contains([x, y]), expected);
    }

    /// A segment is inside exactly when `geo` says the polygon covers it: touching a vertex
    /// or running along an edge is inside, leaving anywhere is not.
    #[test]
    fn contains_segment_agrees_with_geo_covers(
        (z, a, b) in (0usize..3).prop_flat_map(|z| (Just(z), grid_or_boundary_point(z), grid_or_boundary_point(z)))
    ) {
        let ring = &zones()[z];
        let expected = geo_polygon(ring).covers(&geo::Line::new((a[0], a[1]), (b[0], b[1])));
        prop_assert_eq!(Polygon::new(ring).contains_segment(a, b), expected, "{:?} -> {:?}", a, b);
        prop_assert_eq!(segment_inside_polygon(a, b, ring), expected, "{:?} -> {:?}", a, b);
    }

    /// The same answers at the scale and placement of a real fly zone (kilometres from the
    /// origin, rotated, so that "on the boundary" is only true up to rounding).
    #[test]
    fn contains_segment_is_unchanged_by_moving_rotating_and_scaling(
        (z, a, b) in (0usize..3).prop_flat_map(|z| (Just(z), grid_or_boundary_point(z), grid_or_boundary_point(z))),
        rot in 0.0..std::f64::consts::TAU,
        k in 10.0..200.0f64,
        origin in (-5000.0..5000.0f64, -5000.0..5000.0f64),
    ) {
        let (c, s) = (rot.cos(), rot.sin());
        let place = |p: Point| [origin.0 + k * (c * p[0] - s * p[1]), origin.1 + k * (s * p[0] + c * p[1])];
        let ring = &zones()[z];
        let placed: Vec<Point> = ring.iter().map(|p| place(*p)).collect();
        let expected = geo_polygon(ring).covers(&geo::Line::new((a[0], a[1]), (b[0], b[1])));
        prop_assert_eq!(Polygon::new(&placed).contains_segment(place(a), place(b)), expected, "{:?} -> {:?}", a, b);
    }

    /// Every leg between two boundary points of a convex zone (vertices or points on edges)
    /// is inside, however the zone is rotated and placed; pushed out past a vertex, it is not.
    #[test]
    fn legs_between_boundary_points_of_a_convex_zone_are_inside(
        n in 3usize..9,
        rot in 0.0..std::f64::consts::TAU,
        centre in any_point(),
        radius in 50.0..3000.0f64,
        (i, fi) in (0usize..8, prop_oneof![Just(0.0), 0.0..1.0f64]),
        (j, fj) in (0usize..8, prop_oneof![Just(0.0), 0.0..1.0f64]),
    ) {
        let ring: Vec<Point> = (0..n)
            .map(|k| {
                let a = rot + std::f64::consts::TAU * k as f64 / n as f64;
                [centre[0] + radius * a.cos(), centre[1] + radius * a.sin()]
            })
            .collect();
        let zone = Polygon::new(&ring);
        let on_edge = |k: usize, f: f64| lerp(ring[k % n], ring[(k + 1) % n], f);
        let (a, b) = (on_edge(i, fi), on_edge(j, fj));
        prop_assert!(zone.contains(a) && zone.contains(b));
        prop_assert!(zone.contains_segment(a, b), "{:?} -> {:?}", a, b);
        prop_assert!(segment_inside_polygon(a, b, &ring));
        let v = ring[i % n];
        let out = lerp(centre, v, 1.001);
        prop_assert!(!zone.contains_segment(a, out));
    }

    /// Containment of a segment does not depend on its direction.
    #[test]
    fn contains_segment_is_symmetric(z in 0usize..3, a in grid_point(), b in any_point()) {
        let zone = Polygon::new(&zones()[z]);
        prop_assert_eq!(zone.contains_segment(a, b), zone.contains_segment(b, a));
    }

    /// The closest parameter gives the distance, and no sampled point of the segment is closer.
    #[test]
    fn closest_point_on_a_segment_is_closest(p in any_point(), a in any_point(), b in any_point(), f in 0.0..=1.0f64) {
        let t = closest_t_on_segment(p, a, b);
        prop_assert!((0.0..=1.0).contains(&t));
        let d = dist_point_segment(p, a, b);
        assert_relative_eq!(d, dist(p, lerp(a, b, t)), epsilon = 1e-9);
        prop_assert!(d <= dist(p, lerp(a, b, f)) + 1e-9);
        prop_assert!(d <= dist(p, a) + 1e-9 && d <= dist(p, b) + 1e-9);
    }

    /// The boundary distance is zero on the boundary and the distance to some edge elsewhere.
    #[test]
    fn boundary_distance_vanishes_on_edges(z in 0usize..3, k in 0usize..12, f in 0.0..=1.0f64) {
        let ring = &zones()[z];
        let k = k % ring.len();
        let p = lerp(ring[k], ring[(k + 1) % ring.len()], f);
        prop_assert!(distance_to_polygon_boundary(p, ring) <= 1e-12);
        prop_assert!(Polygon::new(ring).boundary_distance(p) <= 1e-12);
    }

    /// Segment intersection is symmetric in its segments and in their directions, and agrees
    /// with `geo` on the grid.
    #[test]
    fn segments_intersect_agrees_with_geo(a in grid_point(), b in grid_point(), c in grid_point(), d in grid_point()) {
        use geo::Intersects;
        let expected = geo::Line::new((a[0], a[1]), (b[0], b[1])).intersects(&geo::Line::new((c[0], c[1]), (d[0], d[1])));
        prop_assert_eq!(segments_intersect(a, b, c, d), expected);
        prop_assert_eq!(segments_intersect(c, d, b, a), expected);
    }

    /// Vector identities: the left normal is orthogonal and counter-clockwise, a unit vector
    /// has length one, the cross product is antisymmetric.
    #[test]
    fn vector_identities(a in any_point(), b in any_point()) {
        assert_relative_eq!(dot(perp(a), a), 0.0, epsilon = 1e-9);
        prop_assert!(cross(a, perp(a)) >= 0.0);
        assert_relative_eq!(cross(a, b), -cross(b, a));
        assert_relative_eq!(norm(perp(a)), norm(a));
        if let Some(u) = unit(sub(a, b)) {
            assert_relative_eq!(norm(u), 1.0, epsilon = 1e-12);
        } else {
            prop_assert!(dist(a, b) <= 1e-12);
        }
        prop_assert_eq!(lerp(a, b, 0.0), a);
        assert_relative_eq!(dist(lerp(a, b, 1.0), b), 0.0, epsilon = 1e-9);
    }

    /// A wrapped angle is in (-pi, pi] and differs from the input by whole turns.
    #[test]
    fn wrap_pi_is_in_range_and_equivalent(a in -100.0..100.0f64) {
        let w = wrap_pi(a);
        prop_assert!(w > -std::f64::consts::PI && w <= std::f64::consts::PI);
        let turns = (a - w) / std::f64::consts::TAU;
        assert_relative_eq!(turns, turns.round(), epsilon = 1e-9);
    }
}
