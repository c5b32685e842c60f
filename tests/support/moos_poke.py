"""A stand-in for MOOS's uPokeDB in its own process, on the independent pymoos2 client (no
uhrisim code): posts each VAR=VALUE (a double where VALUE parses as one, else a string),
waits until the DB hands every one of them back, prints "poked" and exits.

    python moos_poke.py PORT VAR=VALUE [VAR=VALUE ...]

The DB keeps a variable's last value and sends it to whoever registers later, as the real
MOOSDB does: a client that connects after the poke still hears it.
"""

import sys
import time

from pymoos2.core.MOOSCommClient import MOOSCommClient

port = int(sys.argv[1])
pokes = dict(arg.split("=", 1) for arg in sys.argv[2:])
client = MOOSCommClient("127.0.0.1", port, "uPokeDB", comm_tick=20)
client.start()
if not client.wait_until_connected(60.0):
    sys.exit("uPokeDB stand-in: not connected")
for var in pokes:
    client.register(var)
waiting = set(pokes)
deadline = time.time() + 60.0
while waiting and time.time() < deadline:
    for var, text in pokes.items():
        try:
            client.notify(var, float(text))
        except ValueError:
            client.notify(var, text)
    time.sleep(0.1)
    waiting -= {message.key for message in client.fetch()}
client.stop()
if waiting:
    sys.exit(f"uPokeDB stand-in: the DB never handed back {sorted(waiting)}")
print("poked", flush=True)
