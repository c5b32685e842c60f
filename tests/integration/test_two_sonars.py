"""A VideoRay with two sonars (a P900-45 named ``narrow``, a P900-130 named ``wide``) and
a camera (scenarios/videoray_two_sonars.yaml): every output is keyed by its sensor.

The simulation hands out one ping per sonar, keyed ``videoray/narrow`` and
``videoray/wide``, each with its preset's beams; a plain rclpy process receives both
sonars' ProjectedSonarImages (256 and 768 beams, frames ``videoray/narrow`` and
``videoray/wide``) and fans and the camera's pictures, and the three mounts on
/tf_static; the web viewer (headless Chromium) shows both fans side by side and the
camera's picture. The recording of the same scenario is checked in
test_record_rosbag2.py.
"""

from __future__ import annotations

import math
import threading
from pathlib import Path

import numpy as np
import pytest

from tests.support.browser import chromium_unavailable, headless_page
from tests.support.children import Child
from uhrisim.scenario.load import load_scenario
from uhrisim.sensors.sonar.presets import get_preset
from uhrisim.sim.pacing import Pacer
from uhrisim.sim.simulation import Simulation

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "videoray_two_sonars.yaml"
SONARS = {"narrow": "P900-45", "wide": "P900-130"}


def test_each_sonar_pings_under_its_own_key_with_its_own_preset() -> None:
    sim = Simulation(load_scenario(SCENARIO), seed=1)
    seen: dict[str, list] = {}
    while sim.t < 1.0:
        frame = sim.step()
        for key, ping in frame.pings.items():
            seen.setdefault(key, []).append(ping)
        for key in frame.images:
            seen.setdefault(key, []).append(frame.images[key])
    assert set(seen) == {"videoray/narrow", "videoray/wide", "videoray/camera"}
    for name, preset in SONARS.items():
        ping = seen[f"videoray/{name}"][0]
        assert len(ping.beam_angles_rad) == get_preset(preset).n_beams
    # 15 Hz and 5 Hz pings, 10 Hz pictures over the first second
    assert [len(seen[f"videoray/{n}"]) for n in ("narrow", "wide", "camera")] == [15, 5, 10]
    slots = {slot.name: slot for slot in sim.agents["videoray"].sonars}
    assert slots["wide"].sonar.mount_position[2] == pytest.approx(0.05)


def test_both_sonars_and_the_camera_are_published_on_ros2(ros_env: int, tmp_path: Path):
    for package in ("rclpy", "tf2_msgs", "marine_acoustic_msgs"):  # the listener's
        pytest.importorskip(package, reason="python -m uhrisim.bridges.ros2.interfaces")
    from uhrisim.bridges.ros2.hook import Ros2BridgeHook

    hook = Ros2BridgeHook(domain_id=ros_env, node_name="uhrisim_two_sonars", accept=())
    sim = Simulation(load_scenario(SCENARIO), hooks=[hook], seed=1)
    listener = Child("ros2_sensors_listener.py", ["--agent", "videoray", "--sonars", "narrow",
                                                  "wide", "--cameras", "camera"], tmp_path)
    try:
        sim.start()
        listener.expect("READY")
        assert hook.bridge is not None
        assert hook.bridge.wait_for_subscribers(
            ["/videoray/narrow/image", "/videoray/wide/image", "/videoray/camera/image_raw"],
            20.0)
        pacer = Pacer(real_time_factor=2.0)
        pacer.reset(sim.t)
        while sim.t < 3.0:
            pacer.wait(sim.step().t)
        # what is checked below: a first message on each topic
        result = listener.result(counts=dict.fromkeys(
            [f"/videoray/{s}/{kind}" for s in SONARS for kind in ("image", "fan")]
            + ["/videoray/camera/image_raw"], 1))
    finally:
        sim.close()
        if listener.proc.poll() is None:
            listener.proc.kill()
    topics = result["topics"]
    for name, preset in SONARS.items():
        spec = get_preset(preset)
        image = topics[f"/videoray/{name}/image"]
        assert image["count"] > 0 and image["frames"] == [f"videoray/{name}"]
        assert image["first"]["beam_count"] == spec.n_beams
        # the outer beams point at the edges of the preset's field of view
        assert math.degrees(image["first"]["span"]) == pytest.approx(spec.fov_h_deg)
        fan = topics[f"/videoray/{name}/fan"]
        assert fan["count"] > 0 and fan["frames"] == [f"videoray/{name}"]
    # the last range bin (2.54 cm) at each sonar's own range: 10 m and 20 m
    assert topics["/videoray/narrow/image"]["first"]["far_range"] == pytest.approx(10.0,
                                                                                 abs=0.03)
    assert topics["/videoray/wide/image"]["first"]["far_range"] == pytest.approx(20.0,
                                                                               abs=0.03)
    camera = topics["/videoray/camera/image_raw"]
    assert camera["frames"] == ["videoray/camera_optical"]
    assert camera["first"] == {"width": 320, "height": 240}
    assert sorted((p, c) for p, c, _, _ in result["static"]) == [
        ("videoray/base_link", "videoray/camera_optical"),
        ("videoray/base_link", "videoray/narrow"), ("videoray/base_link", "videoray/wide")]


_why = chromium_unavailable()


@pytest.mark.skipif(_why is not None, reason=_why or "")
def test_the_viewer_shows_both_fans_side_by_side_and_the_camera() -> None:
    from uhrisim.viz.viewer import attach_viewer

    sim = Simulation(load_scenario(SCENARIO), seed=1)
    server, hook = attach_viewer(sim, port=0, speed=math.inf)
    stop = threading.Event()
    runner = threading.Thread(target=lambda: sim.run(120.0, should_stop=stop.is_set),
                              daemon=True)
    try:
        with headless_page() as bp:
            page = bp.page
            page.goto(server.url)
            runner.start()
            page.wait_for_function(
                "window.uhri && ['videoray/narrow', 'videoray/wide'].every("
                "k => window.uhri.sonar[k]) && window.uhri.camera['videoray/camera']",
                timeout=90_000)
            page.click("#btn-pause")
            page.wait_for_function("window.uhri.frame.paused === true", timeout=20_000)
            state = page.evaluate("""() => ({
                sonar: Object.fromEntries(Object.entries(window.uhri.sonar).map(
                    ([k, s]) => [k, [s.fov_deg, s.max_range]])),
                caption: document.getElementById('sonar-caption').textContent,
                camera: document.getElementById('camera-caption').textContent})""")
            # each fan's own field of view (deg) and range (m, to the end of its last bin)
            assert state["sonar"]["videoray/narrow"] == pytest.approx([45.0, 10.0], abs=0.03)
            assert state["sonar"]["videoray/wide"] == pytest.approx([130.0, 20.0], abs=0.03)
            assert "videoray/narrow" in state["caption"] and "videoray/wide" in state["caption"]
            assert "videoray/camera" in state["camera"] and "320×240" in state["camera"]
            # the two fans are drawn side by side: both halves of the panel show a fan
            import cv2

            shot = cv2.imdecode(np.frombuffer(page.locator("#sonar").screenshot(), np.uint8),
                                cv2.IMREAD_GRAYSCALE)
            half = shot.shape[1] // 2
            assert (shot[:, :half] > 30).mean() > 0.02 and (shot[:, half:] > 30).mean() > 0.02
            assert bp.errors() == []
    finally:
        stop.set()
        hook.release()
        runner.join(30)
        sim.close()
        server.close()
