"""/tf, /tf_static and marine_acoustic_msgs/ProjectedSonarImage, received by a separate
plain-rclpy process (tests/support/ros2_tf_listener.py) from the bridge on the real
track-and-trail simulation (issue 16).

Expected numbers come from the simulation: a sonar hit's world position is the ping's
sonar pose applied to the ray-cast hit (``position_ned + R @ p_sonar``, NED, converted to
ENU); the chain map -> <agent>/odom -> <agent>/base_link (/tf) -> <agent>/sonar
(/tf_static, from the mount) applied to the published FLU point must land within 1 cm of
it. The ProjectedSonarImage's beams and ranges must be the preset's (the ping's beam
azimuths and bin centres), its directions unit vectors in the message's convention
(Z forward, X up, Y starboard). The helm's decisions arrive as uhrisim_msgs/HelmDecision
with the simulation's numbers.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rclpy")
pytest.importorskip("tf2_msgs", reason="tf2_msgs not built: python -m "
                    "uhrisim.bridges.ros2.interfaces")
pytest.importorskip("marine_acoustic_msgs")
pytest.importorskip("uhrisim_msgs")

from tests.support.children import Child, run_paced_for
from uhrisim.bridges.ros2.hook import Ros2BridgeHook
from uhrisim.core.frames import enu_from_ned
from uhrisim.scenario.load import load_scenario
from uhrisim.sensors.sonar.cloud import cloud_hits
from uhrisim.sim.simulation import Simulation

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "track_and_trail.yaml"


def _matrix(q: list[float]) -> np.ndarray:
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def _resolve(chain: list, points: np.ndarray) -> np.ndarray:
    """Points in the last child frame of ``chain`` (parent first) into its first parent."""
    for _parent, _child, t, q in reversed(chain):
        points = points @ _matrix(q).T + np.asarray(t)
    return points


def test_tf_chain_places_sonar_hits_and_sonar_image_matches_the_preset(
        ros_env: int, tmp_path: Path) -> None:
    hook = Ros2BridgeHook(domain_id=ros_env, node_name="uhrisim_tf_test", odom_rate_hz=None)
    sim = Simulation(load_scenario(SCENARIO), hooks=[hook], seed=1)
    listener = Child("ros2_tf_listener.py", ["--agent", "videoray"], tmp_path)
    pings, decisions = {}, {}

    def keep(frame) -> None:
        if "videoray/sonar" in frame.pings:
            ping = frame.pings["videoray/sonar"]
            sec, ns = divmod(round(ping.t * 1e9), 1_000_000_000)
            pings[f"{sec}.{ns:09d}"] = ping
        if "videoray" in frame.helm:
            sec, ns = divmod(round(frame.t * 1e9), 1_000_000_000)
            decisions[f"{sec}.{ns:09d}"] = frame.helm["videoray"]

    # the diver is in the sonar's view after about 4 s; the listener answers once it has
    # taken every message published meanwhile
    result = run_paced_for(sim, listener, ["/tf", "/tf_static", "/videoray/sonar/points",
                                           "/videoray/sonar/image", "/videoray/helm/decision"],
                           8.0, 2.0, keep)

    # /tf_static: the sonar's mount, once, latched
    static = {(p, c): (t, q) for p, c, t, q in result["static"]}
    assert set(static) == {("videoray/base_link", "videoray/sonar")}  # the diver has none
    mount = ["videoray/base_link", "videoray/sonar", *static[("videoray/base_link",
                                                               "videoray/sonar")]]
    checked = 0
    for stamp, rows in result["points"].items():
        tfs = {(p, c): (t, q) for p, c, t, q in result["tf"].get(stamp, [])}
        if stamp not in pings or ("videoray/odom", "videoray/base_link") not in tfs:
            continue
        chain = [["map", "videoray/odom", *tfs[("map", "videoray/odom")]],
                 ["videoray/odom", "videoray/base_link",
                  *tfs[("videoray/odom", "videoray/base_link")]], mount]
        ping = pings[stamp]
        hits_frd, _ = cloud_hits(ping.cloud)
        truth_enu = enu_from_ned(ping.position_ned + hits_frd @ ping.rotation_ned_from_sonar.T)
        got = _resolve(chain, np.asarray(rows))
        assert got.shape == truth_enu.shape
        np.testing.assert_allclose(got, truth_enu, atol=0.01)  # within 1 cm
        checked += len(rows)
    assert checked > 50, "too few sonar hits resolved through /tf"

    image = result["image"]
    assert image is not None and image["frame_id"] == "videoray/sonar"
    ping = next(iter(pings.values()))
    angles = ping.beam_angles_rad
    directions = np.asarray(image["directions"])
    assert image["beam_count"] == len(angles) == len(directions)
    np.testing.assert_allclose(np.linalg.norm(directions, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(np.arctan2(directions[:, 1], directions[:, 2]), angles,
                               atol=1e-12)
    np.testing.assert_allclose(image["ranges"], ping.bin_ranges_m, rtol=1e-6)  # float32
    assert image["n_data"] == len(angles) * len(ping.bin_ranges_m) and image["dtype"] == 0
    sonar = sim.agents["videoray"].sonars[0].sonar
    assert image["frequency"] == pytest.approx(sonar.config.sonar_spec.frequency_hz)
    assert 1400.0 < image["sound_speed"] < 1600.0

    # the helm's decisions, live as uhrisim_msgs/HelmDecision, each behavior's share in it
    got = result["decisions"]
    assert len(got) >= len(decisions) - 2 > 10
    for stamp, msg in got.items():
        record = decisions[stamp]
        assert msg["mode"] == record.mode and msg["total"] == pytest.approx(record.total)
        assert msg["contributions"] == pytest.approx(dict(record.contributions))
        assert msg["heading"] == pytest.approx(record.heading_deg)
