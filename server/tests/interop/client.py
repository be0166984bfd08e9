"""Drives jink with the PyPI interop client (`suas-interop-clients`), unchanged.

Usage: client.py BASE_URL USERNAME PASSWORD MISSION_ID N

Tries a login with a wrong password, logs in, reads the mission, posts N telemetry
samples (sample i: latitude 38.1445 + i * 1e-5, altitude 150 + i ft, heading i * 13 mod
360) and reads the teams; prints what it saw as one JSON object.
"""

import json
import sys

from interop_clients import InteropClient, InteropError

base, user, password, mission, n = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4]), int(sys.argv[5])
out = {}
try:
    InteropClient(base, user, password + "-wrong")
    out["wrong_password"] = "accepted"
except InteropError:
    out["wrong_password"] = "InteropError"
client = InteropClient(base, user, password)
out["mission"] = client.get_mission(mission)
for i in range(n):
    client.post_telemetry(
        {
            "latitude": 38.1445 + i * 1e-5,
            "longitude": -76.4283,
            "altitude": 150.0 + i,
            "heading": float(i * 13 % 360),
        }
    )
out["teams"] = client.get_teams()
print(json.dumps(out))
