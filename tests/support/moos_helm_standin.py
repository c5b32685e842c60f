"""A stand-in for pHelmIvP in its own process, on the independent pymoos2 client (no
uhrisim code): posts DESIRED_HEADING/SPEED/DEPTH for a while and prints, as one JSON line,
the last NAV_* values it heard.

    python moos_helm_standin.py PORT HEADING SPEED DEPTH SECONDS
"""

import json
import sys
import time

from pymoos2.core.MOOSCommClient import MOOSCommClient

port, heading, speed, depth, seconds = (int(sys.argv[1]), *map(float, sys.argv[2:6]))
client = MOOSCommClient("127.0.0.1", port, "pHelmIvP", comm_tick=20)
client.start()
if not client.wait_until_connected(10.0):
    print(json.dumps({"error": "not connected"}))
    sys.exit(2)
for var in ("NAV_X", "NAV_Y", "NAV_DEPTH", "NAV_HEADING", "NAV_SPEED", "NODE_REPORT"):
    client.register(var)
heard: dict[str, object] = {}
deadline = time.time() + seconds
while time.time() < deadline:
    client.notify("DESIRED_HEADING", heading)
    client.notify("DESIRED_SPEED", speed)
    client.notify("DESIRED_DEPTH", depth)
    time.sleep(0.1)
    for message in client.fetch():
        heard[message.key] = message.val if message.is_double() else message.string()
print(json.dumps(heard))
client.stop()
