#!/usr/bin/env bash
# The API checks, runnable locally from the repository root:
#     tests/client/check.sh
# 1. openapi-spec-validator on the committed openapi/openapi.json;
# 2. a bounded schemathesis pass (all phases, fixed seed) against a real `jink serve`
#    (any free port, a temporary SQLite file);
# 3. openapi-python-client generates a client from the served /openapi.json (warnings fail)
#    and tests/client/roundtrip.py drives the service through its typed calls.
# Tools come from PyPI into a venv (JINK_VENV, default target/api-venv), pinned in
# tests/client/requirements.txt. The binary is built with cargo (CARGO_TARGET_DIR honoured).
set -euo pipefail
cd "$(dirname "$0")/../.."
target="${CARGO_TARGET_DIR:-target}"
venv="$(realpath -m "${JINK_VENV:-$target/api-venv}")"
root="$(pwd)"
work="$(mktemp -d)"
server_pid=""
cleanup() { [ -n "$server_pid" ] && kill "$server_pid" 2>/dev/null; rm -rf "$work"; }
trap cleanup EXIT

timed() { # timed NAME CMD...: runs CMD under a section header and prints how long it took
  local name="$1"; shift
  echo "=== $name"
  local start=$SECONDS
  "$@"
  echo "=== $name: ok in $((SECONDS - start)) s"
}

install_tools() {
  [ -x "$venv/bin/python" ] || python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet --disable-pip-version-check -r tests/client/requirements.txt
}
timed "python tools (pip, tests/client/requirements.txt)" install_tools

timed "openapi-spec-validator openapi/openapi.json" "$venv/bin/openapi-spec-validator" openapi/openapi.json

timed "build jink" cargo build --quiet -p server --bin jink
start_server() {
  "$target/debug/jink" serve --bind 127.0.0.1:0 --database-url "sqlite://$work/jink.sqlite" \
    --log-format json >"$work/stdout" 2>"$work/server.log" &
  server_pid=$!
  for _ in $(seq 1 100); do
    base="$(sed -n 's/^jink listening on //p' "$work/stdout")"
    [ -n "$base" ] && return 0
    sleep 0.1
  done
  echo "jink did not start:"; cat "$work/server.log"; return 1
}
timed "start jink serve" start_server
echo "serving on $base"

seed() { # a mission with traffic and a plan, and a spare mission for DELETE
  local mission_json='{"name": "schemathesis spare", "fly_zones": [{"boundary": [{"lat": 38.0, "lon": -76.0},
    {"lat": 38.01, "lon": -76.0}, {"lat": 38.01, "lon": -75.99}], "alt_min_msl_m": 30, "alt_max_msl_m": 200}],
    "waypoints": [{"lat": 38.002, "lon": -75.998, "alt_msl_m": 100}]}'
  local id_of='import json, sys; print(json.load(sys.stdin)[sys.argv[1]])'
  JINK_MISSION_ID="$(curl -fsS -X POST "$base/api/v1/missions" -H 'content-type: application/json' \
    --data-binary @tests/fixtures/interop/mission_2021_webster_field.json | python3 -c "$id_of" id)"
  JINK_SPARE_MISSION_ID="$(curl -fsS -X POST "$base/api/v1/missions" -H 'content-type: application/json' \
    -d "$mission_json" | python3 -c "$id_of" id)"
  local m="$base/api/v1/missions/$JINK_MISSION_ID"
  curl -fsS -X POST "$m/obstacles" -H 'content-type: application/json' -d '{"observations": [
    {"obstacle_id": "0", "t": 1700000000, "lat": 38.1455, "lon": -76.4245, "alt_msl_m": 60, "radius_m": 20},
    {"obstacle_id": "0", "t": 1700000001, "lat": 38.1455, "lon": -76.42455, "alt_msl_m": 60, "radius_m": 20}]}' >/dev/null
  curl -fsS -X POST "$m/telemetry" -H 'content-type: application/json' \
    -d '{"t": 1700000001, "lat": 38.1447, "lon": -76.428, "alt_msl_m": 61, "heading_deg": 60, "speed_mps": 20}' >/dev/null
  JINK_PLAN_ID="$(curl -fsS -X POST "$m/plan" -H 'content-type: application/json' \
    -d '{"seed": 1, "deadline_ms": 2000}' | python3 -c "$id_of" plan_id)"
  export JINK_MISSION_ID JINK_SPARE_MISSION_ID JINK_PLAN_ID
  echo "mission $JINK_MISSION_ID (spare $JINK_SPARE_MISSION_ID), plan $JINK_PLAN_ID"
}
timed "seed a mission, telemetry and a plan for schemathesis" seed

# Every check, positive_data_acceptance included: the request schemas state the rules the
# validation applies; tests/client/schemathesis.toml names the ids to use and the few
# operations whose cross-field or state rules JSON Schema cannot say.
timed "schemathesis (all phases, seed 1, 10 examples per operation)" \
  "$venv/bin/schemathesis" --config-file tests/client/schemathesis.toml --no-color \
    run "$base/openapi.json" \
    --phases examples,coverage,fuzzing,stateful --seed 1 --max-examples 10 \
    --checks all --generation-database none --workers 1

generate() {
  curl -fsS "$base/openapi.json" -o "$work/openapi.json"
  (cd "$work" && "$venv/bin/openapi-python-client" generate --path openapi.json \
    --meta none --output-path gen/jink_client --config "$root/tests/client/config.yml") \
    2>&1 | tee "$work/generate.log"
  if grep -qi "warning" "$work/generate.log"; then
    echo "openapi-python-client reported warnings"; return 1
  fi
}
timed "openapi-python-client from the served document" generate

timed "typed client round trip (tests/client/roundtrip.py)" \
  "$venv/bin/python" tests/client/roundtrip.py "$base" "$work/gen"
