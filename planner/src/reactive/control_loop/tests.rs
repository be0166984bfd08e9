//! The control loop against scripted sweeps: reports, stopping, pacing, self-check.

use super::*;

/// Replays a fixed list of sweeps and records the commands.
struct Script {
    sweeps: Vec<Vec<Beam>>,
    next: usize,
    sent: Vec<CycleResult>,
}

impl Script {
    fn new(sweeps: Vec<Vec<Beam>>) -> Self {
        Self {
            sweeps,
            next: 0,
            sent: vec![],
        }
    }
}

/// Runs an unpaced loop with default parameters over `h`'s sweeps.
fn run_unpaced(h: &mut Script) -> Result<LoopReport, LoopError<std::io::Error>> {
    ControlLoop::new(unpaced()).unwrap().run(h, None)
}

impl DataHandler for Script {
    type Error = std::io::Error;
    fn read_scan(&mut self, scan: &mut Vec<Beam>) -> Result<Option<ScanMeta>, Self::Error> {
        let Some(s) = self.sweeps.get(self.next) else {
            return Ok(None);
        };
        scan.clear();
        scan.extend_from_slice(s);
        self.next += 1;
        Ok(Some(ScanMeta {
            t_s: self.next as f64 * 0.05,
            goal_distance_m: Some(40.0),
        }))
    }
    fn send_command(&mut self, r: &CycleResult) -> Result<(), Self::Error> {
        self.sent.push(r.clone());
        Ok(())
    }
}

fn sweep(blocked: impl Fn(f64) -> bool) -> Vec<Beam> {
    (0..61)
        .map(|i| {
            let a = -60.0 + 2.0 * i as f64;
            Beam::new(a, if blocked(a) { 1.0 } else { f64::INFINITY })
        })
        .collect()
}

fn unpaced() -> LoopParams {
    LoopParams {
        rate_hz: 0.0,
        ..LoopParams::default()
    }
}

#[test]
fn runs_every_sweep_and_reports() {
    let mut h = Script::new(vec![
        sweep(|_| false),
        sweep(|a| (-20.0..=4.0).contains(&a)),
        sweep(|a| (-4.0..=20.0).contains(&a)),
        sweep(|_| true),
    ]);
    let report = run_unpaced(&mut h).unwrap();
    assert_eq!(report.cycles, 4);
    assert_eq!(report.end, LoopEnd::EndOfData);
    assert_eq!(
        (
            report.left,
            report.right,
            report.no_path,
            report.way_ahead_clear
        ),
        (2, 1, 1, 1)
    );
    let dirs: Vec<_> = h.sent.iter().map(|r| r.decision.direction).collect();
    assert_eq!(
        dirs,
        vec![Some(Side::Left), Some(Side::Left), Some(Side::Right), None]
    );
    // clear ahead: straight path; avoiding: the path leaves to the chosen side
    assert!(h.sent[0].points.iter().all(|p| p.x_m == 0.0));
    assert!(h.sent[1].plan.deviation_m > 0.0 && h.sent[2].plan.deviation_m < 0.0);
    // 16 samples per segment -> 33 points, ending at the goal (40 m ahead)
    assert_eq!(h.sent[1].points.len(), 33);
    assert!((h.sent[1].points[32].y_m - 40.0).abs() < 1e-9);
    assert_eq!(h.sent[3].t_s, 0.2);
}

#[test]
fn stops_at_max_cycles_and_on_the_flag() {
    let mut h = Script::new(vec![sweep(|_| false); 10]);
    let mut l = ControlLoop::new(LoopParams {
        max_cycles: Some(3),
        ..unpaced()
    })
    .unwrap();
    let r = l.run(&mut h, None).unwrap();
    assert_eq!((r.cycles, r.end), (3, LoopEnd::MaxCycles));
    let stop = AtomicBool::new(true);
    let r = l.run(&mut h, Some(&stop)).unwrap();
    assert_eq!((r.cycles, r.end), (0, LoopEnd::Stopped));
}

#[test]
fn paced_loop_runs_at_its_rate_without_asserting_speed() {
    // 200 Hz for 3 cycles: just exercises the sleeping branch
    let mut h = Script::new(vec![sweep(|_| false); 3]);
    let r = ControlLoop::new(LoopParams {
        rate_hz: 200.0,
        ..unpaced()
    })
    .unwrap()
    .run(&mut h, None)
    .unwrap();
    assert_eq!(r.cycles, 3);
}

#[test]
fn self_check_rejects_bad_parts_and_bad_first_sweeps() {
    let mut p = unpaced();
    p.offset.window = 0;
    assert!(matches!(
        ControlLoop::new(p),
        Err(SelfCheckFailure::Parameters(_))
    ));
    let p = LoopParams {
        goal_distance_m: -1.0,
        ..unpaced()
    };
    assert!(matches!(
        ControlLoop::new(p),
        Err(SelfCheckFailure::LoopParameter { .. })
    ));
    // huge thresholds still pass (cycle-0 ties go left)
    let mut p = unpaced();
    p.offset.threshold = 100.0;
    assert!(ControlLoop::new(p).is_ok());

    let mut h = Script::new(vec![vec![]]);
    let e = run_unpaced(&mut h).unwrap_err();
    assert!(matches!(
        e,
        LoopError::SelfCheck(SelfCheckFailure::EmptyFirstScan)
    ));
    let mut bad = sweep(|_| false);
    bad[7].angle_deg = f64::INFINITY;
    let mut h = Script::new(vec![bad]);
    let e = run_unpaced(&mut h).unwrap_err();
    assert!(matches!(
        e,
        LoopError::SelfCheck(SelfCheckFailure::NonFiniteFirstScan { index: 7 })
    ));
    assert!(h.sent.is_empty());
}

#[test]
fn a_rejected_sweep_later_stops_the_loop_with_its_cycle() {
    let mut h = Script::new(vec![sweep(|_| false), vec![]]);
    let e = run_unpaced(&mut h).unwrap_err();
    assert!(matches!(
        e,
        LoopError::Step {
            cycle: 1,
            source: StepError::Offset(OffsetError::EmptyScan)
        }
    ));
    assert_eq!(h.sent.len(), 1);
}
