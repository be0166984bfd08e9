//! Test zones on an integer grid (so `geo`'s exact predicates and ours see the same
//! boundary).

use geom::Point;

/// A U: the notch x in (4, 6), y > 2 is outside.
pub const U: [Point; 8] = [
    [0.0, 0.0],
    [10.0, 0.0],
    [10.0, 10.0],
    [6.0, 10.0],
    [6.0, 2.0],
    [4.0, 2.0],
    [4.0, 10.0],
    [0.0, 10.0],
];

/// Non-convex zones: the U, a comb with two notches, an arrow with a reflex vertex.
#[allow(dead_code)]
pub fn zones() -> Vec<Vec<Point>> {
    vec![
        U.to_vec(),
        vec![
            [0.0, 0.0],
            [10.0, 0.0],
            [10.0, 8.0],
            [8.0, 8.0],
            [8.0, 4.0],
            [6.0, 4.0],
            [6.0, 8.0],
            [4.0, 8.0],
            [4.0, 4.0],
            [2.0, 4.0],
            [2.0, 8.0],
            [0.0, 8.0],
        ],
        vec![[0.0, 0.0], [10.0, 5.0], [0.0, 10.0], [4.0, 5.0]],
    ]
}
