//! Hand-written SVG plots of a run: fly zone, waypoints, cylinders (solid when they matter at
//! some mission altitude, dashed otherwise), the spheres' true tracks with their final
//! positions, the aircraft's track, and hits marked in red.

use std::fmt::Write;

use crate::geometry::xy;
use crate::mission::{bounds_m, fly_zone};
use crate::run::RunResult;
use crate::scenario::Scenario;

const COLORS: [&str; 10] = [
    "#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22",
    "#17becf", "#d62728",
];

/// The `points` attribute of an SVG polyline or polygon: `x,y` pairs in pixels.
fn svg_points(
    points: impl IntoIterator<Item = [f64; 2]>,
    to_px: impl Fn([f64; 2]) -> [f64; 2],
) -> String {
    let pairs: Vec<String> = points
        .into_iter()
        .map(|p| {
            let q = to_px(p);
            format!("{:.1},{:.1}", q[0], q[1])
        })
        .collect();
    pairs.join(" ")
}

/// An SVG document (about 800 px wide) of `run` on `scenario`.
pub fn plot_run(scenario: &Scenario, run: &RunResult) -> String {
    let m = &scenario.mission;
    let (mut lo, mut hi) = bounds_m(m);
    for p in &run.track {
        lo = [lo[0].min(p[1]), lo[1].min(p[2])];
        hi = [hi[0].max(p[1]), hi[1].max(p[2])];
    }
    let pad = 60.0;
    let (w_m, h_m) = (hi[0] - lo[0] + 2.0 * pad, hi[1] - lo[1] + 2.0 * pad);
    let px = 800.0;
    let k = px / w_m;
    let height = h_m * k;
    // ENU -> SVG (y down)
    let tx = |x: f64| (x - lo[0] + pad) * k;
    let ty = |y: f64| (hi[1] + pad - y) * k;
    let px_of = |p: [f64; 2]| [tx(p[0]), ty(p[1])];
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{px:.0}" height="{:.0}" viewBox="0 0 {px:.0} {:.0}" font-family="sans-serif" font-size="12">"#,
        height + 40.0,
        height + 40.0
    );
    let _ = writeln!(s, r##"<rect width="100%" height="100%" fill="#ffffff"/>"##);
    let _ = writeln!(
        s,
        r##"<polygon points="{}" fill="#f4fbf4" stroke="#2e7d32" stroke-width="2"/>"##,
        svg_points(fly_zone(m).iter().copied(), px_of)
    );
    let min_alt = m
        .waypoints
        .iter()
        .map(|w| w.alt_m)
        .fold(f64::INFINITY, f64::min);
    for (i, c) in m.cylinders.iter().enumerate() {
        let hit = run.judge.cylinder_hits.get(i).copied().unwrap_or(false);
        let dash = if c.top_m < min_alt {
            r#" stroke-dasharray="4 3""#
        } else {
            ""
        };
        let _ = writeln!(
            s,
            r##"<circle cx="{:.1}" cy="{:.1}" r="{:.1}" fill="{}" fill-opacity="0.35" stroke="{}" stroke-width="{}"{dash}/>"##,
            tx(c.center_m[0]),
            ty(c.center_m[1]),
            c.radius_m * k,
            if hit { "#e53935" } else { "#9e9e9e" },
            if hit { "#b71c1c" } else { "#424242" },
            if hit { 3 } else { 1 },
        );
        let _ = writeln!(
            s,
            r##"<text x="{:.1}" y="{:.1}" fill="#424242">top {:.0} m</text>"##,
            tx(c.center_m[0]) - 20.0,
            ty(c.center_m[1]) + 4.0,
            c.top_m
        );
    }
    let t_end = run.track.last().map_or(scenario.duration_s, |p| p[0]);
    for (i, sp) in scenario.spheres.iter().enumerate() {
        let col = COLORS[i % COLORS.len()];
        let hit = run.judge.sphere_hits.get(i).copied().unwrap_or(false);
        let n = (t_end / 1.0).ceil() as usize;
        let _ = writeln!(
            s,
            r#"<polyline points="{}" fill="none" stroke="{col}" stroke-width="1" stroke-opacity="0.6"/>"#,
            svg_points((0..=n).map(|j| xy(sp.track.at(j as f64))), px_of)
        );
        let end = sp.track.at(t_end);
        let _ = writeln!(
            s,
            r##"<circle cx="{:.1}" cy="{:.1}" r="{:.1}" fill="{col}" fill-opacity="0.15" stroke="{}" stroke-width="{}"/>"##,
            tx(end[0]),
            ty(end[1]),
            sp.radius_m * k,
            if hit { "#b71c1c" } else { col },
            if hit { 3 } else { 1 },
        );
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" fill="{col}">{} {}</text>"#,
            tx(end[0]) + 4.0,
            ty(end[1]) - 4.0,
            i,
            sp.behaviour.kind().name()
        );
    }
    // mission legs
    let legs = std::iter::once(xy(scenario.start_m)).chain(m.waypoints.iter().map(|w| w.p_m));
    let _ = writeln!(
        s,
        r##"<polyline points="{}" fill="none" stroke="#000" stroke-width="1" stroke-dasharray="6 4"/>"##,
        svg_points(legs, px_of)
    );
    // aircraft track, red where inside some obstacle at that time
    let _ = writeln!(
        s,
        r##"<polyline points="{}" fill="none" stroke="#0d47a1" stroke-width="2"/>"##,
        svg_points(run.track.iter().map(|p| [p[1], p[2]]), px_of)
    );
    for p in &run.track {
        let q = [p[1], p[2], p[3]];
        let in_sphere = scenario.spheres.iter().any(|sp| {
            let c = sp.track.at(p[0]);
            ((q[0] - c[0]).powi(2) + (q[1] - c[1]).powi(2) + (q[2] - c[2]).powi(2)).sqrt()
                <= sp.radius_m
        });
        let in_cyl = m
            .cylinders
            .iter()
            .any(|c| crate::scoring::cylinder_clearance_m(q, c) <= 0.0);
        if in_sphere || in_cyl {
            let _ = writeln!(
                s,
                r##"<circle cx="{:.1}" cy="{:.1}" r="3" fill="#e53935"/>"##,
                tx(q[0]),
                ty(q[1])
            );
        }
    }
    for (i, w) in m.waypoints.iter().enumerate() {
        let w = [w.p_m[0], w.p_m[1], w.alt_m];
        let got = run
            .judge
            .waypoints_captured
            .get(i)
            .copied()
            .unwrap_or(false);
        let _ = writeln!(
            s,
            r##"<circle cx="{:.1}" cy="{:.1}" r="{:.1}" fill="none" stroke="{}" stroke-width="1.5"/><text x="{:.1}" y="{:.1}">{} ({:.0} m)</text>"##,
            tx(w[0]),
            ty(w[1]),
            crate::scoring::WAYPOINT_CAPTURE_M * k,
            if got { "#2e7d32" } else { "#e53935" },
            tx(w[0]) + 6.0,
            ty(w[1]) + 14.0,
            i,
            w[2]
        );
    }
    let st = xy(scenario.start_m);
    let _ = writeln!(
        s,
        r##"<rect x="{:.1}" y="{:.1}" width="8" height="8" fill="#000"/>"##,
        tx(st[0]) - 4.0,
        ty(st[1]) - 4.0
    );
    let mm = &run.metrics;
    let _ = writeln!(
        s,
        r##"<text x="8" y="{:.0}" font-size="14">{} seed {} / {}: spheres hit {}/{}, cylinders hit {}/{}, waypoints {}/{}, path ratio {:.2}, min clearance {:.1} m</text>"##,
        height + 25.0,
        scenario.family.name(),
        scenario.seed,
        run.strategy.name(),
        mm.spheres_hit,
        mm.spheres,
        mm.cylinders_hit,
        mm.cylinders,
        mm.waypoints_captured,
        mm.waypoints,
        mm.path_ratio,
        mm.min_clearance_m
    );
    s.push_str("</svg>\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn svg_points_are_pixel_pairs_to_one_decimal() {
        let flip = |p: [f64; 2]| [2.0 * p[0], 100.0 - p[1]];
        assert_eq!(
            svg_points([[0.0, 0.0], [1.25, 10.0]], flip),
            "0.0,100.0 2.5,90.0"
        );
        assert_eq!(svg_points([], flip), "");
    }
}
