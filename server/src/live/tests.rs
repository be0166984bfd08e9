//! Tests of the live-state registry: map eviction and reuse across missions.

use super::*;
use crate::app::Settings;
use crate::store::Store;

/// A SQLite state keeping at most one map, with two Webster missions ("a", "b") of
/// three obstacles over 10 s.
async fn two_missions(dir: &tempfile::TempDir) -> (AppState, Mission, Mission) {
    let url = format!("sqlite://{}", dir.path().join("live.sqlite").display());
    let store = Store::open(&url).await.expect("open");
    let cfg = LiveConfig {
        max_maps: 1,
        ..LiveConfig::default()
    };
    let state = AppState::new(
        store,
        Settings {
            live: cfg,
            ..Settings::default()
        },
    );
    let text = include_str!("../../../tests/fixtures/interop/mission_2021_webster_field.json");
    let a = wire::domain::read_mission_text(text, "a").expect("fixture");
    let b = wire::domain::read_mission_text(text, "b").expect("fixture");
    state
        .store
        .insert_missions(&[a.clone(), b.clone()], 0.0)
        .await
        .expect("missions");
    for m in [&a, &b] {
        for i in 0..50 {
            let t = 1_700_000_000.0 + 0.2 * f64::from(i);
            let rows: Vec<ObservationRow> = (0..3)
                .map(|k| ObservationRow {
                    obstacle_id: k.to_string(),
                    t_s: t,
                    lat_deg: 38.145 + 0.0001 * f64::from(i) + 0.001 * f64::from(k),
                    lon_deg: -76.429,
                    alt_msl_m: 60.0,
                    radius_m: 20.0,
                })
                .collect();
            state
                .store
                .insert_observations(&m.id, &rows, t)
                .await
                .expect("insert");
        }
    }
    (state, a, b)
}

fn cells(s: &Snapshot) -> Vec<f32> {
    let map = s.map.as_ref().expect("map");
    (0..60)
        .flat_map(|k| map.slice(map.t0_s() + f64::from(k)).data)
        .collect()
}

#[tokio::test]
async fn maps_are_built_only_for_map_reads_and_at_most_max_maps_are_kept() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (state, a, b) = two_missions(&dir).await;
    let live = &state.live;
    // The obstacle list reads the predictor alone: no map is built.
    let view = live.predictor_view(&state, &a).await.expect("view");
    assert_eq!((view.seq, view.predictor.obstacles().count()), (50, 3));
    let la = live.cached(&a.id).expect("live");
    assert!(!la.has_map());
    // A map read builds it.
    let first = live.snapshot(&state, &a).await.expect("snapshot");
    assert_eq!(first.seq, 50);
    assert!(la.has_map());
    // A map of another mission drops the least recently read one (max_maps = 1)...
    let sb = live.snapshot(&state, &b).await.expect("snapshot");
    assert!(sb.map.is_some());
    assert!(!la.has_map());
    assert!(live.cached(&b.id).expect("live").has_map());
    // ... and it comes back, the same cells bit for bit, when read again.
    let again = live.snapshot(&state, &a).await.expect("snapshot");
    assert!(!Arc::ptr_eq(&first, &again));
    assert_eq!(again.map_ids, first.map_ids);
    assert_eq!(cells(&again), cells(&first));
}

#[tokio::test]
async fn a_map_dropped_for_max_maps_is_kept_for_the_next_build() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (state, a, b) = two_missions(&dir).await;
    let live = &state.live;
    let first = cells(&live.snapshot(&state, &a).await.expect("snapshot"));
    assert_eq!(lock(&live.spare_maps).len(), 0);
    // b's map drops a's (max_maps = 1); nobody reads a's any more, so its allocation is
    // kept for the next build instead of freed...
    drop(live.snapshot(&state, &b).await.expect("snapshot"));
    assert!(!live.cached(&a.id).expect("live").has_map());
    assert_eq!(lock(&live.spare_maps).len(), 1);
    // ... which takes it (and b's map, dropped in turn, is kept), the cells the same bit
    // for bit as the first build's.
    let again = live.snapshot(&state, &a).await.expect("snapshot");
    assert_eq!(cells(&again), first);
    assert_eq!(lock(&live.spare_maps).len(), 1);
    assert!(!live.cached(&b.id).expect("live").has_map());
}

/// Stores a batch of one observation of `obstacle_id` (60 m MSL, 20 m radius) at `t_s`
/// for mission `m`.
async fn insert_one(
    state: &AppState,
    m: &Mission,
    obstacle_id: &str,
    t_s: f64,
    lat_deg: f64,
    lon_deg: f64,
) -> StoredBatch {
    let rows = [ObservationRow {
        obstacle_id: obstacle_id.into(),
        t_s,
        lat_deg,
        lon_deg,
        alt_msl_m: 60.0,
        radius_m: 20.0,
    }];
    state
        .store
        .insert_observations(&m.id, &rows, t_s)
        .await
        .expect("insert")
        .expect("mission")
}

/// The next batch of mission "a": a new obstacle ("3"), one tick after the fixture's last
/// row.
async fn one_more_batch(state: &AppState, m: &Mission) -> StoredBatch {
    insert_one(state, m, "3", 1_700_000_000.0 + 0.2 * 50.0, 38.147, -76.427).await
}

#[tokio::test]
async fn a_plan_takes_the_published_snapshot_while_a_batch_is_young_and_waits_once_it_is_old() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (state, a, _) = two_missions(&dir).await;
    let live = state.live.entry(&a);
    let (first, lag) = live
        .plan_snapshot(&state, Duration::from_secs(1))
        .await
        .expect("snapshot");
    assert_eq!((first.seq, lag), (50, MapLag::default()));
    // A batch applied without its background rebuild (as when it lands between a plan's
    // reads), moving a known obstacle: a plan within the age bound takes the published
    // snapshot, whole. Obstacle "0" goes 55 m from where the predictor last took it (the
    // fixture's first row: its later rows move 55 m/s, faster than an obstacle can, and
    // are passed over).
    let t = 1_700_000_000.0 + 0.2 * 50.0;
    let batch = insert_one(&state, &a, "0", t, 38.1455, -76.429).await;
    assert_eq!(batch.seq, 51);
    live.apply(&state, &batch).await.expect("apply");
    let (young, lag) = live
        .plan_snapshot(&state, Duration::from_secs(1))
        .await
        .expect("snapshot");
    assert_eq!((young.seq, lag.batches), (50, 1));
    assert!(lag.age_ms >= 0.0 && lag.age_ms < 1000.0, "{lag:?}");
    assert!(Arc::ptr_eq(&young, &first), "the same published snapshot");
    assert_eq!(young.anchor_t_s, first.anchor_t_s);
    // Beyond the bound (0: read your writes) the plan waits for the map of batch 51.
    let (current, lag) = live
        .plan_snapshot(&state, Duration::ZERO)
        .await
        .expect("snapshot");
    assert_eq!((current.seq, lag), (51, MapLag::default()));
    assert!(current.anchor_t_s > first.anchor_t_s);
    // A batch that brings a new obstacle is never skipped, however young it is.
    let batch = one_more_batch(&state, &a).await;
    assert_eq!(batch.seq, 52);
    live.apply(&state, &batch).await.expect("apply");
    let (with_new, lag) = live
        .plan_snapshot(&state, Duration::from_secs(1))
        .await
        .expect("snapshot");
    assert_eq!((with_new.seq, lag), (52, MapLag::default()));
    assert_eq!(with_new.map_ids, ["0", "1", "2", "3"]);
    assert_eq!(current.map_ids, ["0", "1", "2"]);
    // Its predictor and map hold batch 52 and nothing is mixed: the same as a rebuild of
    // batches 1..=52 from the store.
    let rows: Vec<ObservationRow> = state
        .store
        .list_observations_through(&a.id, -1, 52)
        .await
        .expect("rows")
        .into_iter()
        .map(|(_, r)| r)
        .collect();
    let mut p = Predictor::new(snapshot::predictor_config());
    snapshot::feed(&mut p, &a.frame(), &rows);
    let rebuilt = Snapshot::build(&a, 52, Arc::new(p));
    assert_eq!(cells(&with_new), cells(&rebuilt));
}

/// Batch `k` (52, 53, ...) of mission "a": obstacle "0" one tick further on.
async fn batch_number(state: &AppState, m: &Mission, k: i64) -> StoredBatch {
    let t = 1_700_000_000.0 + 0.2 * (k - 1) as f64;
    let batch = insert_one(state, m, "0", t, 38.145 + 0.0001 * (k - 1) as f64, -76.429).await;
    assert_eq!(batch.seq, k);
    batch
}

#[tokio::test]
async fn batches_arriving_while_the_cpu_is_taken_cost_one_background_rebuild_after_the_foreground_work()
 {
    let dir = tempfile::tempdir().expect("tempdir");
    let (state, a, _) = two_missions(&dir).await;
    // The map is in use (read by a plan), so each batch asks for a rebuild.
    let live = state.live.entry(&a);
    live.plan_snapshot(&state, Duration::ZERO)
        .await
        .expect("snapshot");
    let built = live.builds.load(Ordering::Relaxed);
    // Every CPU slot busy with foreground work (a plan computing).
    let slots: Vec<CpuPermit> = futures_util::future::join_all(
        (0..state.cpu.slots()).map(|_| state.cpu.acquire(Priority::Foreground)),
    )
    .await;
    for k in 51..=60 {
        let batch = batch_number(&state, &a, k).await;
        state.live.apply(&state, &a.id, &batch).await;
    }
    // A plan's computation queued now goes before the rebuild the batches queued.
    let order = Arc::new(Mutex::new(Vec::new()));
    let fg = {
        let (state, order, live) = (state.clone(), order.clone(), live.clone());
        tokio::spawn(async move {
            let _p = state.cpu.acquire(Priority::Foreground).await;
            lock(&order).push(live.published().seq);
        })
    };
    for _ in 0..20 {
        tokio::task::yield_now().await;
    }
    assert_eq!(
        live.published().seq,
        50,
        "no rebuild while the CPU is taken"
    );
    drop(slots);
    fg.await.expect("foreground job");
    let deadline = Instant::now() + Duration::from_secs(30);
    while live.published().seq < 60 {
        assert!(Instant::now() < deadline, "the rebuild never came");
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    assert_eq!(
        *lock(&order),
        [50],
        "the foreground job ran before the rebuild"
    );
    assert_eq!(
        live.builds.load(Ordering::Relaxed) - built,
        1,
        "one rebuild for ten batches"
    );
}
