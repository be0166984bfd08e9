"""Round trip through the Python client that openapi-python-client generates from the
served /openapi.json, using only its typed calls.

Usage: roundtrip.py BASE_URL GENERATED_DIR   (tests/client/check.sh runs it)

Exits non-zero on the first step that does not answer as documented.
"""

import json
import pathlib
import sys

base_url, generated = sys.argv[1], sys.argv[2]
sys.path.insert(0, generated)

from jink_client import Client  # noqa: E402
from jink_client.api.missions import create_mission, get_mission  # noqa: E402
from jink_client.api.plans import create_plan, get_plan, get_plan_qgc, get_plan_wpl  # noqa: E402
from jink_client.api.prediction import get_risk, get_risk_png, list_obstacles  # noqa: E402
from jink_client.api.telemetry import post_obstacles, post_telemetry  # noqa: E402
from jink_client.types import File  # noqa: E402
from jink_client.models import (  # noqa: E402
    AircraftTelemetry,
    SourceFormat,
    Interop2019Mission,
    Mission,
    MissionInput,
    ObservationBatch,
    ObservationIn,
    PlanBody,
    PlanOut,
    Problem,
    RiskSliceOut,
)

ROOT = pathlib.Path(__file__).resolve().parents[2]
client = Client(base_url=base_url, raise_on_unexpected_status=True)


def step(name, response, status, model):
    parsed = response.parsed
    ok = response.status_code == status and isinstance(parsed, model)
    print(f"  {'ok  ' if ok else 'FAIL'} {name}: {response.status_code} {type(parsed).__name__}")
    if not ok:
        print(response.content.decode(errors="replace")[:2000])
        sys.exit(1)
    return parsed


native = {
    "name": "roundtrip",
    "fly_zones": [{
        "boundary": [{"lat": 38.0, "lon": -76.0}, {"lat": 38.01, "lon": -76.0},
                     {"lat": 38.01, "lon": -75.99}, {"lat": 38.0, "lon": -75.99}],
        "alt_min_msl_m": 30.0, "alt_max_msl_m": 200.0,
    }],
    "waypoints": [{"lat": 38.002, "lon": -75.998, "alt_msl_m": 100.0},
                  {"lat": 38.008, "lon": -75.992, "alt_msl_m": 120.0}],
    "stationary_obstacles": [{"lat": 38.005, "lon": -75.995, "radius_m": 40.0, "top_msl_m": 150.0}],
}
mission = step("upload the native mission",
               create_mission.sync_detailed(client=client, body=MissionInput.from_dict(native)),
               201, Mission)
mid = mission.id
again = step("read it back", get_mission.sync_detailed(mid, client=client), 200, Mission)
assert again.home.lat == 38.0 and len(again.waypoints) == 2, again

webster = json.loads((ROOT / "tests/fixtures/interop/mission_2021_webster_field.json").read_text())
interop = step("upload the 2021 interop mission",
               create_mission.sync_detailed(client=client, body=Interop2019Mission.from_dict(webster),
                                            format_=SourceFormat.INTEROP_2019),
               201, Mission)
assert interop.source_format.value == "interop-2019" and len(interop.fly_zones[0].boundary) == 12, interop

obs = ObservationBatch(observations=[
    ObservationIn(obstacle_id="intruder", t=1_700_000_000.0 + i, lat=38.004 + 0.0001 * i,
                  lon=-75.996, alt_msl_m=100.0, radius_m=20.0)
    for i in range(5)
])
step("post obstacle observations", post_obstacles.sync_detailed(mid, client=client, body=obs), 202, object)
step("post aircraft telemetry",
     post_telemetry.sync_detailed(mid, client=client, body=AircraftTelemetry(
         t=1_700_000_004.0, lat=38.002, lon=-75.998, alt_msl_m=100.0, heading_deg=45.0, speed_mps=20.0)),
     202, object)
obstacles = step("list obstacles", list_obstacles.sync_detailed(mid, client=client), 200, list)
assert any(o.to_dict().get("id") == "intruder" for o in obstacles), [o.to_dict() for o in obstacles]

plan = step("plan", create_plan.sync_detailed(mid, client=client, body=PlanBody(seed=7)), 201, PlanOut)
assert plan.seed == 7 and plan.revision == 1, plan
fetched = step("get the plan as JSON", get_plan.sync_detailed(mid, plan.plan_id, client=client), 200, PlanOut)
assert fetched.plan_id == plan.plan_id

wpl = step("download the plan as QGC WPL", get_plan_wpl.sync_detailed(mid, plan.plan_id, client=client), 200, str)
lines = wpl.splitlines()
assert lines[0] == "QGC WPL 110" and len(lines) == 2 + len(plan.waypoints), lines[:3]
qgc = step("download the plan as a QGroundControl .plan",
           get_plan_qgc.sync_detailed(mid, plan.plan_id, client=client), 200, object)
qgc = qgc.to_dict()
assert qgc["fileType"] == "Plan" and len(qgc["mission"]["items"]) == len(plan.waypoints), qgc

risk = step("read the risk map", get_risk.sync_detailed(mid, client=client, t=10.0), 200, RiskSliceOut)
assert len(risk.values) == risk.width * risk.height > 0, (risk.width, risk.height)
png = step("read the risk map as a PNG", get_risk_png.sync_detailed(mid, client=client, t=10.0), 200, File)
assert png.payload.read(8) == b"\x89PNG\r\n\x1a\n", "a PNG"

step("a second plan on revision 1", create_plan.sync_detailed(
    mid, client=client, body=PlanBody(seed=7, base_revision=1)), 201, PlanOut)
conflict = step("a stale base revision is a typed 409 problem", create_plan.sync_detailed(
    mid, client=client, body=PlanBody(seed=7, base_revision=1)), 409, Problem)
assert conflict.status == 409 and conflict.type_ == "urn:jink:problem:conflict", conflict

bad = json.loads(json.dumps(native))
bad["waypoints"][1]["lat"] = 91.0
invalid = step("an invalid latitude is a typed 422 problem naming the field",
               create_mission.sync_detailed(client=client, body=MissionInput.from_dict(bad)), 422, Problem)
assert any(e.pointer == "/waypoints/1/lat" for e in invalid.errors), invalid

print("round trip: every step answered as documented")
