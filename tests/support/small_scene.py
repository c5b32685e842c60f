"""The small scene the refusal tests break one thing of at a time: a VideoRay and a diver
on a script over a flat floor with a crate (tests/integration/test_scenario_refusals.py;
tests/integration/test_scenario_bounds.py adds a helm, sensors, bubbles and metrics)."""

SMALL_SCENE = """\
name: refusals
duration: 10
physics_rate_hz: 60
world:
  seafloor: {type: flat, depth: 8, extent: 50}
  objects:
    - {type: box, label: crate, size: [2, 2, 2], position: {north: 10, east: 10, depth: 7}}
agents:
  - name: rov
    model: videoray
    start: {north: 0, east: 0, depth: 1, heading_deg: 0}
    driver: none
  - name: diver
    model: diver
    driver: script
    start: {north: 5, east: 0, depth: 2, heading_deg: 0}
    script:
      - {t: 0, heading_deg: 90, speed: 0.3, depth: 2}
      - {t: 5, heading_deg: 180, speed: 0.3, depth: 2}
recording: {odometry_rate_hz: 10}
"""
