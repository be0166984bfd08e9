//! One reactive control cycle on a 360-beam sweep: Offset Algorithm + Pilot (+ sampling),
//! and the sector avoider, reusing buffers as the onboard loop does. Target: <= 20 us per
//! offset + pilot cycle on one core (the 50 Hz budget is 20 ms).

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use planner::reactive::{
    Beam, OffsetParams, OffsetWorkspace, PathPoint, PilotInput, PilotParams, SectorParams,
    pilot_plan, sectors_decide,
};

/// 360 beams, 1 degree apart, an obstacle 4 m away over -25..+10 degrees, a wall at 2 m
/// behind, no returns elsewhere. The Offset Algorithm needs several cycles to get left.
fn sweep() -> Vec<Beam> {
    (0..360)
        .map(|i| {
            let a = f64::from(i) - 180.0;
            let d = if (-25.0..=10.0).contains(&a) {
                4.0
            } else if a.abs() > 120.0 {
                2.0
            } else {
                f64::INFINITY
            };
            Beam::new(a, d)
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let scan = sweep();
    let ranges: Vec<f64> = scan.iter().map(|b| b.distance_m).collect();
    let offset = OffsetParams::default();
    let pilot = PilotParams::default();
    let sectors = SectorParams::default().with_obj_threshold_m(5.0);
    let mut ws = OffsetWorkspace::new();
    let mut path: Vec<PathPoint> = Vec::with_capacity(64);

    c.bench_function("offset+pilot cycle, 360 beams", |b| {
        b.iter(|| {
            let d = ws.decide(black_box(&scan), &offset).unwrap();
            let plan = pilot_plan(&PilotInput::new(d.deviation_m, 20.0, 80.0), &pilot).unwrap();
            plan.sample_into(16, &mut path);
            black_box((d, path.len()))
        })
    });
    c.bench_function("sectors, 360 beams", |b| {
        b.iter(|| black_box(sectors_decide(black_box(&ranges), -180.0, &sectors).unwrap()))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
