//! The closed boundary rule (issue 10) on hand-picked legs of a U-shaped zone: vertices and
//! edges are inside, chords through the notch are not.

use geom::{Polygon, point_in_polygon, segment_inside_polygon};

mod common;
use common::U;

#[test]
fn a_chord_of_a_u_shaped_zone_leaves_it() {
    let u = Polygon::new(&U);
    assert!(u.contains([2.0, 8.0]) && u.contains([8.0, 8.0]));
    assert!(!u.contains([5.0, 8.0]));
    assert!(!u.contains_segment([2.0, 8.0], [8.0, 8.0]));
    assert!(u.contains_segment([2.0, 1.0], [8.0, 1.0]));
}

#[test]
fn boundary_points_are_inside() {
    let u = Polygon::new(&U);
    for v in U {
        assert!(u.contains(v), "{v:?}");
        assert!(point_in_polygon(v, &U), "{v:?}");
    }
    assert!(u.contains([5.0, 0.0]) && u.contains([0.0, 5.0]) && u.contains([5.0, 2.0]));
    assert!(!u.contains([5.0, 2.0 + 1e-3]) && !u.contains([-1e-3, 5.0]));
}

#[test]
fn legs_touching_a_vertex_or_along_an_edge_are_inside() {
    let u = Polygon::new(&U);
    let cases = [
        // vertex to vertex along an edge
        ([0.0, 0.0], [10.0, 0.0]),
        // along part of an edge
        ([1.0, 0.0], [3.0, 0.0]),
        // interior point to a vertex
        ([2.0, 5.0], [0.0, 10.0]),
        // a vertex to the notch floor's corner, across the interior below the notch
        ([0.0, 0.0], [4.0, 2.0]),
        // along the notch floor, vertex to vertex
        ([4.0, 2.0], [6.0, 2.0]),
    ];
    for (a, b) in cases {
        assert!(u.contains_segment(a, b), "{a:?} {b:?}");
        assert!(u.contains_segment(b, a), "{b:?} {a:?}");
        assert!(segment_inside_polygon(a, b, &U), "{a:?} {b:?}");
    }
}

#[test]
fn legs_between_boundary_points_across_the_outside_are_not_inside() {
    let u = Polygon::new(&U);
    // The two top corners of the notch, and two points on its inner walls: the chord
    // between them runs through the notch without crossing an edge properly.
    assert!(!u.contains_segment([4.0, 10.0], [6.0, 10.0]));
    assert!(!u.contains_segment([4.0, 5.0], [6.0, 5.0]));
    assert!(!segment_inside_polygon([4.0, 5.0], [6.0, 5.0], &U));
    // From the bottom edge through the notch floor's corner (4, 2), touching it, then
    // into the notch up to its right wall.
    assert!(!u.contains_segment([2.0, 0.0], [6.0, 4.0]));
    assert!(!segment_inside_polygon([2.0, 0.0], [6.0, 4.0], &U));
    // Along the outside of an edge's extension: (10, 0) -> (12, 0) leaves.
    assert!(!u.contains_segment([10.0, 0.0], [12.0, 0.0]));
}

#[test]
fn a_point_segment_is_its_point() {
    let u = Polygon::new(&U);
    assert!(u.contains_segment([1.0, 1.0], [1.0, 1.0]));
    assert!(u.contains_segment([0.0, 0.0], [0.0, 0.0]));
    assert!(!u.contains_segment([5.0, 8.0], [5.0, 8.0]));
}

#[test]
fn fewer_than_three_vertices_contain_nothing() {
    let p = Polygon::new(&[[0.0, 0.0], [1.0, 0.0]]);
    assert!(!p.contains([0.5, 0.0]));
    assert!(!point_in_polygon([0.5, 0.0], &[[0.0, 0.0], [1.0, 0.0]]));
}

#[test]
fn a_closed_ring_answers_like_an_open_one() {
    let mut closed = U.to_vec();
    closed.push(U[0]);
    assert_eq!(Polygon::new(&closed), Polygon::new(&U));
    assert!(point_in_polygon([2.0, 8.0], &closed) && !point_in_polygon([5.0, 8.0], &closed));
    assert!(!segment_inside_polygon([2.0, 8.0], [8.0, 8.0], &closed));
    assert!(segment_inside_polygon([0.0, 0.0], [10.0, 0.0], &closed));
}
