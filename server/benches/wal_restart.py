"""Which SQLite commit pays for starting the WAL over (README: "The WAL started over by the
background", under "Live mission state").

A 10-row observation batch transaction on the store's schema (its migrations), 600 commits 30 ms apart,
with a PASSIVE checkpoint (on a second connection) before every third commit. The WAL mode
and pragmas are the store's (`synchronous=NORMAL`, no auto-checkpoint). Modes:

- `restart`: after a checkpoint that copied the whole WAL, the next commit starts the WAL
  over, and SQLite syncs the new WAL header inside that commit;
- `prime`: as `jink serve` does since 2026-12-02 (`store::wal::start_over`), a one-frame
  write of the checkpoint's own (`PRAGMA user_version` set to its value) starts it over,
  outside the timed commits;
- `none`: no checkpoint at all (the WAL only grows).

Usage: python3 server/benches/wal_restart.py restart|prime|none [DIR]
Prints the commits' latency p50 / p90 / p99 / max in ms. Timings vary with the machine;
compare modes run one after the other.
"""

import os
import sqlite3
import sys
import tempfile
import time

# The store's schema: the repository's own SQLite migrations, applied in order.
MIGRATIONS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "migrations", "sqlite")
INSERT = (
    "INSERT INTO obstacle_observations (mission_id, obstacle_id, t_us, lat_deg, lon_deg, "
    "alt_msl_m, radius_m, received_at_us, seq, written_by) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)"
)
PRAGMAS = [
    "PRAGMA journal_mode=WAL",
    "PRAGMA synchronous=NORMAL",
    "PRAGMA foreign_keys=ON",
    "PRAGMA wal_autocheckpoint=0",
]


def main() -> None:
    mode = sys.argv[1] if len(sys.argv) > 1 else ""
    if mode not in ("restart", "prime", "none"):
        sys.exit(__doc__)
    with tempfile.TemporaryDirectory(dir=sys.argv[2] if len(sys.argv) > 2 else None) as d:
        path = os.path.join(d, "w.sqlite")
        write = sqlite3.connect(path, isolation_level=None)
        read = sqlite3.connect(path, isolation_level=None)
        for p in PRAGMAS:
            write.execute(p)
            read.execute(p)
        for name in sorted(os.listdir(MIGRATIONS)):
            with open(os.path.join(MIGRATIONS, name), encoding="utf-8") as f:
                write.executescript(f.read())
        write.execute(
            "INSERT INTO missions (id, created_at_us, source_format, body) VALUES ('m', 0, 'native', '{}')"
        )
        ms = []
        for i in range(600):
            time.sleep(0.03)
            if i % 3 == 0 and mode != "none":
                busy, log, copied = read.execute("PRAGMA wal_checkpoint(PASSIVE)").fetchone()
                if mode == "prime" and busy == 0 and log > 1 and copied == log:
                    v = write.execute("PRAGMA user_version").fetchone()[0]
                    write.execute(f"PRAGMA user_version={v}")
                time.sleep(0.03)
            rows = [
                ("m", str(k), 1_700_000_000_000_000 + i * 200_000, 38.1 + k * 1e-4, -76.4,
                 60.0, 10.0, 1, i + 1, "local")
                for k in range(10)
            ]
            start = time.perf_counter()
            write.execute("BEGIN")
            write.execute("UPDATE missions SET obs_seq = obs_seq + 1 WHERE id = 'm'")
            write.executemany(INSERT, rows)
            write.execute("COMMIT")
            ms.append((time.perf_counter() - start) * 1e3)
        ms.sort()
        n = len(ms)
        print(
            f"{mode}: commit ms p50 {ms[n // 2]:.3f} p90 {ms[int(n * 0.9)]:.3f} "
            f"p99 {ms[int(n * 0.99) - 1]:.3f} max {ms[-1]:.3f}"
        )


if __name__ == "__main__":
    main()
