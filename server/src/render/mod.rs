//! Pictures of a mission, drawn with the `tiny-skia` rasterizer and encoded as PNG.
//!
//! [`risk_png`] draws one risk-map slice (seed 002) as a heatmap with the mission on top:
//! what `GET /api/v1/missions/{id}/risk/png` answers. Labels (the slice's time, the
//! legend's values) use [`font`], a 3x5 pixel font of the few characters they need, since
//! the rasterizer draws no text.

mod font;

use tiny_skia::{
    Color, FillRule, Paint, PathBuilder, Pixmap, PremultipliedColorU8, Rect, Stroke, Transform,
};

use crate::geodesy::LocalFrame;
use crate::mission::Mission;

/// A moving obstacle as drawn: its fitted position and velocity, and its radius.
#[derive(Debug, Clone, Copy)]
pub struct Mover {
    /// Fitted position, ENU metres.
    pub p_m: [f64; 2],
    /// Fitted velocity, ENU m/s.
    pub v_mps: [f64; 2],
    /// Sphere radius, metres.
    pub radius_m: f64,
}

/// The aircraft and the current plan, drawn over the map, and the slice's clock time.
#[derive(Debug, Clone, Default)]
pub struct Overlay {
    /// The aircraft's newest position (ENU metres) and compass heading (degrees).
    pub aircraft: Option<([f64; 2], f64)>,
    /// The current plan from the item before the one flown toward: each item's position
    /// (ENU metres) and whether the planner inserted it (an avoid waypoint).
    pub plan: Vec<([f64; 2], bool)>,
    /// The slice's time, Unix seconds, drawn as UTC (None: not drawn).
    pub t_s: Option<f64>,
}

/// Width of the legend panel right of the map, pixels.
pub const LEGEND_W_PX: u32 = 72;
/// Legend colour bar: left edge (from the panel's left), width, top and height, pixels.
pub const LEGEND_BAR: (u32, u32, u32, u32) = (8, 16, 54, 200);
/// The map's pixels per cell, for a slice of `width` x `height` cells: the map is at most
/// about 900 pixels on its longer side, 1 to 8 pixels per cell.
pub fn pixels_per_cell(width: usize, height: usize) -> u32 {
    (900 / width.max(height).max(1)).clamp(1, 8) as u32
}

/// Heat colour of a probability: white below 0.005, then pale yellow -> orange -> dark red
/// on a square-root scale (so that a spread-out cloud of a few percent per cell shows).
pub fn heat(p: f32) -> [u8; 3] {
    let lerp = |a: [f32; 3], b: [f32; 3], f: f32| -> [u8; 3] {
        [0, 1, 2].map(|i| (a[i] + (b[i] - a[i]) * f).round().clamp(0.0, 255.0) as u8)
    };
    let p = p.clamp(0.0, 1.0);
    if p <= 0.005 {
        return [250, 250, 250];
    }
    let r = p.sqrt();
    if r < 0.5 {
        lerp([255.0, 240.0, 170.0], [255.0, 140.0, 0.0], r / 0.5)
    } else {
        lerp([255.0, 140.0, 0.0], [170.0, 0.0, 0.0], (r - 0.5) / 0.5)
    }
}

/// Colours of the overlays.
pub mod colour {
    /// Fly-zone boundaries.
    pub const FLY_ZONE: [u8; 3] = [0, 90, 200];
    /// Waypoints.
    pub const WAYPOINT: [u8; 3] = [0, 140, 0];
    /// Legs between waypoints.
    pub const LEG: [u8; 3] = [60, 170, 60];
    /// Stationary cylinders.
    pub const CYLINDER: [u8; 3] = [20, 20, 20];
    /// Moving obstacles.
    pub const MOVER: [u8; 3] = [200, 0, 200];
    /// The current plan's legs.
    pub const PLAN: [u8; 3] = [0, 110, 0];
    /// Avoid waypoints of the current plan.
    pub const AVOID: [u8; 3] = [192, 86, 0];
    /// The aircraft.
    pub const AIRCRAFT: [u8; 3] = [10, 61, 145];
    /// The 100 m grid.
    pub const GRID: [u8; 3] = [225, 225, 225];
    /// Scale bar, north arrow, labels.
    pub const INK: [u8; 3] = [0, 0, 0];
}

fn paint(c: [u8; 3]) -> Paint<'static> {
    let mut p = Paint::default();
    p.set_color_rgba8(c[0], c[1], c[2], 255);
    p.anti_alias = true;
    p
}

/// The path through `pts` in order, closed when `close` (None with fewer than two points).
fn path_through(pts: &[(f32, f32)], close: bool) -> Option<tiny_skia::Path> {
    let mut pb = PathBuilder::new();
    for (i, &(x, y)) in pts.iter().enumerate() {
        if i == 0 {
            pb.move_to(x, y);
        } else {
            pb.line_to(x, y);
        }
    }
    if close {
        pb.close();
    }
    pb.finish()
}

/// The canvas: a pixmap and the affine map from ENU metres to its pixels.
struct Canvas {
    pixmap: Pixmap,
    origin_m: [f64; 2],
    px_per_m: f64,
    map_h: f64,
}

impl Canvas {
    fn px(&self, p_m: [f64; 2]) -> (f32, f32) {
        let x = (p_m[0] - self.origin_m[0]) * self.px_per_m;
        let y = self.map_h - (p_m[1] - self.origin_m[1]) * self.px_per_m;
        (x as f32, y as f32)
    }

    fn polyline(&mut self, pts: &[(f32, f32)], close: bool, c: [u8; 3], width: f32) {
        if let Some(path) = path_through(pts, close) {
            let stroke = Stroke {
                width,
                ..Stroke::default()
            };
            self.pixmap
                .stroke_path(&path, &paint(c), &stroke, Transform::identity(), None);
        }
    }

    fn circle(&mut self, (x, y): (f32, f32), r: f32, c: [u8; 3], width: Option<f32>) {
        let Some(path) = PathBuilder::from_circle(x, y, r.max(0.5)) else {
            return;
        };
        match width {
            Some(width) => {
                let stroke = Stroke {
                    width,
                    ..Stroke::default()
                };
                self.pixmap
                    .stroke_path(&path, &paint(c), &stroke, Transform::identity(), None);
            }
            None => self.pixmap.fill_path(
                &path,
                &paint(c),
                FillRule::Winding,
                Transform::identity(),
                None,
            ),
        }
    }

    fn polygon(&mut self, pts: &[(f32, f32)], c: [u8; 3]) {
        if let Some(path) = path_through(pts, true) {
            self.pixmap.fill_path(
                &path,
                &paint(c),
                FillRule::Winding,
                Transform::identity(),
                None,
            );
        }
    }

    fn rect(&mut self, x: f32, y: f32, w: f32, h: f32, c: [u8; 3]) {
        if let Some(r) = Rect::from_xywh(x, y, w, h) {
            let mut p = paint(c);
            p.anti_alias = false;
            self.pixmap.fill_rect(r, &p, Transform::identity(), None);
        }
    }

    fn text(&mut self, x: f32, y: f32, s: &str, c: [u8; 3]) {
        let scale = 2.0;
        for (i, ch) in s.chars().enumerate() {
            let x0 = x + i as f32 * 4.0 * scale;
            for (row, bits) in font::glyph(ch).iter().enumerate() {
                for col in 0..3 {
                    if bits & (0b100 >> col) != 0 {
                        self.rect(
                            x0 + col as f32 * scale,
                            y + row as f32 * scale,
                            scale,
                            scale,
                            c,
                        );
                    }
                }
            }
        }
    }
}

/// Draws `slice` as a PNG, north up: the risk heatmap ([`heat`]) on a light 100 m grid,
/// the fly zones, waypoints and legs, the stationary cylinders, the moving obstacles at
/// their fitted positions (a disc, a circle of their radius and a line 10 s along their
/// velocity), the current plan (its legs dark green, avoid waypoints orange diamonds), the
/// aircraft (a blue arrow along its heading), a 100 m scale bar, a north arrow, and right
/// of the map a legend panel: the slice's time (`t+Ns`, seconds after the map's anchor,
/// and its UTC clock time) above the colour bar (probability 1 at the top, 0 at the
/// bottom).
///
/// The map is `width x height` cells at [`pixels_per_cell`]; the legend panel adds
/// [`LEGEND_W_PX`] on the right.
///
/// # Errors
/// PNG encoding failed.
pub fn risk_png(
    slice: &predictor::SliceView,
    frame: &LocalFrame,
    mission: &Mission,
    movers: &[Mover],
    overlay: &Overlay,
    t_ahead_s: f64,
) -> Result<Vec<u8>, png::EncodingError> {
    let s = pixels_per_cell(slice.width, slice.height);
    let (map_w, map_h) = (
        (slice.width as u32 * s).max(1),
        (slice.height as u32 * s).max(1),
    );
    let (w, h) = (
        map_w + LEGEND_W_PX,
        map_h.max(LEGEND_BAR.2 + LEGEND_BAR.3 + 30),
    );
    let mut pixmap = Pixmap::new(w, h).ok_or(png::EncodingError::LimitsExceeded)?;
    pixmap.fill(Color::WHITE);
    let mut cv = Canvas {
        pixmap,
        origin_m: slice.origin_m,
        px_per_m: f64::from(s) / slice.cell_m,
        map_h: f64::from(map_h),
    };
    let px_per_m = cv.px_per_m as f32;

    // Light 100 m grid, under the risk.
    let (east_m, north_m) = (
        slice.width as f64 * slice.cell_m,
        slice.height as f64 * slice.cell_m,
    );
    let mut gx = (slice.origin_m[0] / 100.0).ceil() * 100.0;
    while gx < slice.origin_m[0] + east_m {
        let (x, _) = cv.px([gx, 0.0]);
        cv.polyline(&[(x, 0.0), (x, map_h as f32)], false, colour::GRID, 1.0);
        gx += 100.0;
    }
    let mut gy = (slice.origin_m[1] / 100.0).ceil() * 100.0;
    while gy < slice.origin_m[1] + north_m {
        let (_, y) = cv.px([0.0, gy]);
        cv.polyline(&[(0.0, y), (map_w as f32, y)], false, colour::GRID, 1.0);
        gy += 100.0;
    }
    // Risk cells.
    {
        let stride = w as usize;
        let pixels = cv.pixmap.pixels_mut();
        for (image_row, col, [r, g, b]) in risk_cells(slice) {
            let c = PremultipliedColorU8::from_rgba(r, g, b, 255)
                .expect("opaque colours are valid premultiplied colours");
            let y0 = image_row as u32 * s;
            for y in y0..y0 + s {
                let start = y as usize * stride + (col as u32 * s) as usize;
                pixels[start..start + s as usize].fill(c);
            }
        }
    }
    for z in &mission.content.fly_zones {
        let pts: Vec<(f32, f32)> = z
            .boundary
            .iter()
            .map(|p| cv.px(frame.to_enu(p.lat, p.lon)))
            .collect();
        cv.polyline(&pts, true, colour::FLY_ZONE, 3.0);
    }
    let wps: Vec<(f32, f32)> = mission
        .content
        .waypoints
        .iter()
        .map(|p| cv.px(frame.to_enu(p.lat, p.lon)))
        .collect();
    cv.polyline(&wps, false, colour::LEG, 1.0);
    for &p in &wps {
        cv.circle(p, 4.0, colour::WAYPOINT, None);
    }
    for c in &mission.content.stationary_obstacles {
        let p = cv.px(frame.to_enu(c.lat, c.lon));
        cv.circle(p, c.radius_m as f32 * px_per_m, colour::CYLINDER, Some(3.0));
        cv.circle(p, 2.0, colour::CYLINDER, None);
    }
    for m in movers {
        let c = cv.px(m.p_m);
        cv.circle(c, m.radius_m as f32 * px_per_m, colour::MOVER, Some(3.0));
        cv.circle(c, 3.0, colour::MOVER, None);
        let tip = cv.px([m.p_m[0] + 10.0 * m.v_mps[0], m.p_m[1] + 10.0 * m.v_mps[1]]);
        cv.polyline(&[c, tip], false, colour::MOVER, 2.0);
    }
    let plan: Vec<(f32, f32)> = overlay.plan.iter().map(|(p, _)| cv.px(*p)).collect();
    cv.polyline(&plan, false, colour::PLAN, 3.0);
    for (&(x, y), (_, avoid)) in plan.iter().zip(&overlay.plan) {
        if *avoid {
            cv.polygon(
                &[(x, y - 7.0), (x + 7.0, y), (x, y + 7.0), (x - 7.0, y)],
                colour::AVOID,
            );
        }
    }
    if let Some((p, heading_deg)) = overlay.aircraft {
        let (x, y) = cv.px(p);
        let (s, c) = (heading_deg.to_radians() as f32).sin_cos();
        // Compass heading: x east = sin, y south (pixels down) = -cos.
        let at = |fwd: f32, right: f32| (x + fwd * s + right * c, y - fwd * c + right * s);
        let arrow = [at(14.0, 0.0), at(-9.0, 9.0), at(-4.0, 0.0), at(-9.0, -9.0)];
        cv.polygon(&arrow, colour::AIRCRAFT);
    }
    // 100 m scale bar, bottom left.
    let y = map_h as f32 - 12.0;
    let xe = 10.0 + 100.0 * px_per_m;
    cv.polyline(&[(10.0, y), (xe, y)], false, colour::INK, 3.0);
    cv.polyline(&[(10.0, y - 5.0), (10.0, y + 5.0)], false, colour::INK, 2.0);
    cv.polyline(&[(xe, y - 5.0), (xe, y + 5.0)], false, colour::INK, 2.0);
    // North arrow, top right of the map.
    let (ax, ay) = (map_w as f32 - 20.0, 10.0);
    cv.polyline(&[(ax, ay + 30.0), (ax, ay)], false, colour::INK, 2.0);
    cv.polyline(
        &[(ax - 7.0, ay + 10.0), (ax, ay), (ax + 7.0, ay + 10.0)],
        false,
        colour::INK,
        2.0,
    );
    draw_legend(&mut cv, map_w, t_ahead_s, overlay.t_s);
    encode(&cv.pixmap)
}

/// The legend panel right of the map: the time label, the colour bar with its ticks.
fn draw_legend(cv: &mut Canvas, map_w: u32, t_ahead_s: f64, t_s: Option<f64>) {
    let x0 = map_w as f32;
    cv.polyline(
        &[(x0 + 0.5, 0.0), (x0 + 0.5, cv.map_h as f32)],
        false,
        colour::GRID,
        1.0,
    );
    cv.text(
        x0 + 6.0,
        8.0,
        &format!("t+{}s", t_ahead_s.round()),
        colour::INK,
    );
    if let Some(t) = t_s {
        let day_s = t.rem_euclid(86_400.0).floor() as u32;
        let hms = format!(
            "{:02}:{:02}:{:02}",
            day_s / 3600,
            day_s / 60 % 60,
            day_s % 60
        );
        cv.text(x0 + 4.0, 22.0, &hms, colour::INK);
        cv.text(x0 + 6.0, 36.0, "UTC", colour::INK);
    }
    let (bx, bw, by, bh) = LEGEND_BAR;
    let (bx, by) = (x0 + bx as f32, by as f32);
    for i in 0..bh {
        // Row i shows the probability at its middle, 1 at the top.
        let p = 1.0 - (i as f32 + 0.5) / bh as f32;
        cv.rect(bx, by + i as f32, bw as f32, 1.0, heat(p));
    }
    cv.polyline(
        &[
            (bx, by),
            (bx + bw as f32, by),
            (bx + bw as f32, by + bh as f32),
            (bx, by + bh as f32),
        ],
        true,
        colour::INK,
        1.0,
    );
    for (p, label) in [(1.0, "1"), (0.5, ".5"), (0.1, ".1"), (0.0, "0")] {
        let y = by + (1.0 - p) * bh as f32;
        cv.polyline(
            &[(bx + bw as f32, y), (bx + bw as f32 + 4.0, y)],
            false,
            colour::INK,
            1.0,
        );
        cv.text(bx + bw as f32 + 7.0, y - 5.0, label, colour::INK);
    }
}

/// The risk layer alone, one pixel per cell, north up: [`heat`] colours, transparent
/// where the probability is at most 0.005 (what the operator's page lays under its
/// drawing; the same colours as [`risk_png`]).
///
/// # Errors
/// PNG encoding failed.
pub fn risk_layer_png(slice: &predictor::SliceView) -> Result<Vec<u8>, png::EncodingError> {
    let (w, h) = (slice.width.max(1), slice.height.max(1));
    let mut rgba = vec![0u8; w * h * 4];
    for (image_row, col, [r, g, b]) in risk_cells(slice) {
        let i = (image_row * w + col) * 4;
        rgba[i..i + 4].copy_from_slice(&[r, g, b, 255]);
    }
    encode_rgba(w as u32, h as u32, &rgba)
}

/// The cells whose probability is above 0.005, as `(image row, column, heat colour)`:
/// image rows run north to south (row 0 northernmost), the slice's rows south to north.
fn risk_cells(slice: &predictor::SliceView) -> impl Iterator<Item = (usize, usize, [u8; 3])> + '_ {
    (0..slice.height).flat_map(move |row| {
        (0..slice.width).filter_map(move |col| {
            let p = slice.data[row * slice.width + col];
            (p > 0.005).then(|| (slice.height - 1 - row, col, heat(p)))
        })
    })
}

/// Encodes an opaque pixmap as an 8-bit RGBA PNG (premultiplied = straight when opaque).
fn encode(pixmap: &Pixmap) -> Result<Vec<u8>, png::EncodingError> {
    encode_rgba(pixmap.width(), pixmap.height(), pixmap.data())
}

/// Encodes straight 8-bit RGBA pixels, rows top first, as a PNG.
fn encode_rgba(width: u32, height: u32, rgba: &[u8]) -> Result<Vec<u8>, png::EncodingError> {
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, width, height);
        enc.set_color(png::ColorType::Rgba);
        enc.set_depth(png::BitDepth::Eight);
        let mut writer = enc.write_header()?;
        writer.write_image_data(rgba)?;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn decode(bytes: &[u8]) -> (u32, u32, Vec<u8>) {
        let dec = png::Decoder::new(std::io::Cursor::new(bytes));
        let mut reader = dec.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!(info.color_type, png::ColorType::Rgba);
        buf.truncate(info.buffer_size());
        (info.width, info.height, buf)
    }

    fn rgb(img: &(u32, u32, Vec<u8>), x: u32, y: u32) -> [u8; 3] {
        let i = ((y * img.0 + x) * 4) as usize;
        [img.2[i], img.2[i + 1], img.2[i + 2]]
    }

    /// A 500 m x 400 m slice at 10 m (8 pixels per cell): certain risk in the cell east
    /// and north of the origin, a mover at (-100, 100) m, a cylinder at (150, -100) m.
    #[test]
    fn risk_obstacles_and_the_legend_are_where_they_belong() {
        let mission = wire::domain::read_mission_text(
            r#"{"fly_zones": [{"boundary": [{"lat": 37.998, "lon": -76.003}, {"lat": 38.002, "lon": -76.003},
                {"lat": 38.002, "lon": -75.997}, {"lat": 37.998, "lon": -75.997}],
                "alt_min_msl_m": 0, "alt_max_msl_m": 300}],
                "home": {"lat": 38.0, "lon": -76.0},
                "waypoints": [{"lat": 37.9985, "lon": -76.0025, "alt_msl_m": 100}],
                "stationary_obstacles": [{"lat": 37.9991, "lon": -75.99829, "radius_m": 30, "top_msl_m": 200}]}"#,
            "render",
        )
        .unwrap();
        let (width, height) = (50, 40);
        let mut data = vec![0.0f32; width * height];
        data[20 * width + 25] = 1.0;
        let slice = predictor::SliceView {
            t_s: 5.0,
            origin_m: [-250.0, -200.0],
            cell_m: 10.0,
            width,
            height,
            data,
        };
        let movers = [Mover {
            p_m: [-100.0, 100.0],
            v_mps: [0.0, 0.0],
            radius_m: 20.0,
        }];
        // The aircraft at (-200, -100) m heading east; the plan from (-200, -100) m through
        // an avoid waypoint at (0, -150) m to (200, -100) m.
        let overlay = Overlay {
            aircraft: Some(([-200.0, -100.0], 90.0)),
            plan: vec![
                ([-200.0, -100.0], false),
                ([0.0, -150.0], true),
                ([200.0, -100.0], false),
            ],
            t_s: Some(1_700_000_000.0 + 3661.0),
        };
        let png = risk_png(&slice, &mission.frame(), &mission, &movers, &overlay, 5.0).unwrap();
        let img = decode(&png);
        assert_eq!(pixels_per_cell(width, height), 8);
        assert_eq!((img.0, img.1), (400 + LEGEND_W_PX, 320));
        // Cell (row 20, col 25): x 200..208, y (39 - 20) * 8 = 152..160.
        assert_eq!(rgb(&img, 204, 156), heat(1.0));
        // Its neighbour carries no risk: the white background (grid lines every 100 m are
        // at x = 40, 120, 200, 280, 360 and y = 80, 160, 240).
        assert_eq!(rgb(&img, 212, 156), [255, 255, 255]);
        // The mover's centre disc: x (-100 + 250) * 0.8 = 120, y 320 - 300 * 0.8 = 80.
        assert_eq!(rgb(&img, 120, 80), colour::MOVER);
        // Its radius circle, 20 m = 16 px west of the centre.
        assert_eq!(rgb(&img, 104, 80), colour::MOVER);
        // Between the disc and the circle: nothing.
        assert_eq!(rgb(&img, 114, 86), [255, 255, 255]);
        // The aircraft: x (-200 + 250) * 0.8 = 40, y 320 - 100 * 0.8 = 240; its nose points
        // east (ahead of the centre), its tail notch leaves the point behind it clear.
        assert_eq!(rgb(&img, 44, 240), colour::AIRCRAFT);
        assert_ne!(rgb(&img, 34, 240), colour::AIRCRAFT);
        // The avoid waypoint's diamond: x 250 * 0.8 = 200, y 320 - 50 * 0.8 = 280.
        assert_eq!(rgb(&img, 200, 282), colour::AVOID);
        // The plan's leg from it to the last item, halfway: (100, -125) m -> (280, 260).
        assert_eq!(rgb(&img, 280, 260), colour::PLAN);
        // The legend bar: dark red at the top, pale near the bottom, the time label above.
        let (bx, _, by, bh) = LEGEND_BAR;
        let top = rgb(&img, 400 + bx + 8, by + 2);
        assert!(top[0] >= 165 && top[1] < 10 && top[2] < 10, "{top:?}");
        let low = rgb(&img, 400 + bx + 8, by + bh - 4);
        assert!(low[0] == 255 && low[1] > 200, "{low:?}");
        // Ink pixels in the legend's column between rows `ys`.
        let ink = |ys: std::ops::Range<u32>| {
            (400..img.0)
                .flat_map(|x| ys.clone().map(move |y| (x, y)))
                .filter(|&(x, y)| rgb(&img, x, y) == colour::INK)
                .count()
        };
        let label_ink = ink(8..18);
        assert!(
            label_ink > 20,
            "the time label is drawn: {label_ink} ink pixels"
        );
        // 1_700_003_661 s is 23:14:21 UTC: eight characters of clock time under it.
        let clock_ink = ink(22..32);
        assert!(
            clock_ink > 60,
            "the clock time is drawn: {clock_ink} ink pixels"
        );
    }

    #[test]
    fn the_risk_layer_has_one_pixel_per_cell_north_up_and_is_clear_without_risk() {
        let (width, height) = (4, 3);
        let mut data = vec![0.0f32; width * height];
        // Row 0 is the southernmost: its cell 1 is the image's bottom row.
        data[1] = 1.0;
        data[2 * width + 3] = 0.25;
        let slice = predictor::SliceView {
            t_s: 0.0,
            origin_m: [0.0, 0.0],
            cell_m: 10.0,
            width,
            height,
            data,
        };
        let img = decode(&risk_layer_png(&slice).unwrap());
        assert_eq!((img.0, img.1), (4, 3));
        let px = |x: u32, y: u32| {
            let i = ((y * img.0 + x) * 4) as usize;
            [img.2[i], img.2[i + 1], img.2[i + 2], img.2[i + 3]]
        };
        assert_eq!(px(1, 2), [170, 0, 0, 255]);
        assert_eq!(px(3, 0), [255, 140, 0, 255]);
        assert_eq!(px(0, 0)[3], 0, "no risk: transparent");
        assert_eq!(px(1, 0)[3], 0);
    }

    #[test]
    fn heat_is_white_at_zero_and_dark_red_at_one() {
        assert_eq!(heat(0.0), [250, 250, 250]);
        assert_eq!(heat(1.0), [170, 0, 0]);
        assert_eq!(heat(0.25), [255, 140, 0]);
    }
}
