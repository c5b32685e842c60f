"""A carried load in the VideoRay's eqs 1-4: inertia, heave force, hover thrust, trim."""

import math

import numpy as np
import pytest

from uhrisim.dynamics import carried_load as cl
from uhrisim.dynamics import videoray
from uhrisim.dynamics.free_body import GRAVITY, WATER_DENSITY, Hydro
from uhrisim.dynamics.integrators import rk4_step

PAPER = videoray.VideoRayParams()  # linear map, 4 N at full vertical input
QUADRATIC = videoray.VideoRayParams(thrust_map="quadratic")
GRIPPER = (0.22, 0.0, 0.13)


def loaded_xdot(load):
    """``xdot_loaded`` with the signature the integrators take: f(t, x, u, params)."""
    return lambda t, x, u, params: cl.xdot_loaded(t, x, u, params, load)


def tool_of(kgf_in_water, volume=1e-4, position=GRIPPER):
    """A compact tool whose in-water weight is ``kgf_in_water`` kilograms-force."""
    mass = kgf_in_water + WATER_DENSITY * volume
    return cl.CarriedLoad(Hydro(mass, volume, 1.0, 0.004), position)


def test_inertias_and_drag_add_up():
    load = tool_of(0.3)
    loaded = cl.loaded_params(PAPER, load)
    m = load.hydro.mass + 0.5 * WATER_DENSITY * 1e-4
    assert loaded.m11 == pytest.approx(PAPER.m11 + m)
    assert loaded.m33 == pytest.approx(PAPER.m33 + m)
    added_yaw_inertia = loaded.J - PAPER.J
    assert added_yaw_inertia == pytest.approx(m * 0.22 ** 2)  # parallel-axis theorem
    assert loaded.Xuu == pytest.approx(PAPER.Xuu - 0.5 * WATER_DENSITY * 1.0 * 0.004)
    # the same thrust accelerates the loaded vehicle less: in the ratio of the inertias
    x = np.zeros(8)
    u = np.array([100.0, 100.0, 0.0])
    ratio = (videoray.xdot(0, x, u, loaded)[4] / videoray.xdot(0, x, u, PAPER)[4])
    assert ratio == pytest.approx(PAPER.m11 / loaded.m11)


def test_a_held_tool_pulls_the_vehicle_down_with_its_in_water_weight():
    load = tool_of(0.3)
    loaded = cl.loaded_params(PAPER, load)
    d = cl.xdot_loaded(0.0, np.zeros(8), np.zeros(3), PAPER, load)
    assert d[6] == pytest.approx(0.3 * GRAVITY / loaded.m33)
    # batch-aware like videoray.xdot
    batch = cl.xdot_loaded(0.0, np.zeros((5, 8)), np.zeros((5, 3)), PAPER, load)
    np.testing.assert_allclose(batch, np.broadcast_to(d, (5, 8)))


@pytest.mark.parametrize("params", [PAPER, QUADRATIC], ids=["linear", "quadratic"])
def test_the_extra_hover_thrust_equals_the_weight_through_the_thruster_map(params):
    """0.2 kgf in water: the hover command's thrust is exactly W = 1.96 N (linear map:
    73.5 units; quadratic: sqrt(W / Ct_up) = 128.4 units), and with it the vehicle holds
    depth: from rest, 60 s of RK4 on the loaded eqs 1-4 leave it where it was."""
    load = tool_of(0.2)
    hover = cl.hover_command(params, load)
    assert not hover.saturated and hover.steady_heave == 0.0
    thrust = float(videoray.thruster_forces(np.array([0.0, 0.0, hover.command]), params)[2])
    assert thrust == pytest.approx(0.2 * GRAVITY, rel=1e-12)
    if params.thrust_map == "linear":
        assert hover.command == pytest.approx(0.2 * GRAVITY / (4.0 / 150.0))
    x = np.array([0.0, 0.0, 5.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    u = np.array([0.0, 0.0, hover.command])
    for _ in range(3600):
        x = rk4_step(loaded_xdot(load), 0.0, x, u, params, 1 / 60)
    assert x[2] == pytest.approx(5.0, abs=1e-9) and abs(x[6]) < 1e-12
    # without the extra thrust it sinks
    assert cl.xdot_loaded(0.0, x, np.zeros(3), params, load)[6] > 0.0


@pytest.mark.parametrize("params", [PAPER, QUADRATIC], ids=["linear", "quadratic"])
def test_a_tool_heavier_than_the_vertical_thrust_saturates_and_sinks(params):
    """1 kgf in water (9.81 N) needs more than the vertical thruster gives (4 N with the
    authors' linear map, 2.68 N with Wang's quadratic one): the command saturates at the
    limit and the vehicle sinks at the steady speed where heave damping takes the rest;
    RK4 on the loaded equations reaches that speed."""
    load = tool_of(1.0)
    assert cl.max_hover_weight(params) < load.in_water_weight
    hover = cl.hover_command(params, load)
    assert hover.saturated and hover.command == params.input_limit
    assert hover.needed_command > params.input_limit
    loaded = cl.loaded_params(params, load)
    rest = load.in_water_weight - cl.max_hover_weight(params)
    w = hover.steady_heave
    assert loaded.Zw * w + loaded.Zww * abs(w) * w + rest == pytest.approx(0.0, abs=1e-9)
    x = np.array([0.0, 0.0, 5.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    u = np.array([0.0, 0.0, hover.command])
    for _ in range(600):
        x = rk4_step(loaded_xdot(load), 0.0, x, u, params, 1 / 60)
    assert x[6] == pytest.approx(w, rel=1e-6) and x[2] > 5.0


def test_the_paper_vehicle_holds_at_most_0_41_kgf():
    assert cl.max_hover_weight(PAPER) / GRAVITY == pytest.approx(4.0 / GRAVITY)  # 0.408
    assert cl.max_hover_weight(QUADRATIC) == pytest.approx(1.19e-4 * 150 ** 2)  # 2.68 N


def test_an_off_centre_load_trims_the_vehicle():
    load = tool_of(0.2, position=(0.2, 0.0, 0.1))
    roll, pitch = cl.trim_angles(load)
    righting = cl.VIDEORAY_MASS_KG * GRAVITY * cl.VIDEORAY_BG_M
    assert roll == 0.0
    assert pitch == pytest.approx(-math.asin(0.2 * 0.2 * GRAVITY / righting))  # bow down
    assert math.degrees(pitch) == pytest.approx(-19.5, abs=0.5)
    starboard = cl.trim_angles(tool_of(0.1, position=(0.0, 0.1, 0.1)))
    assert starboard[0] > 0.0  # starboard side down
    assert math.isnan(cl.trim_angles(tool_of(1.0, position=(0.3, 0.0, 0.1)))[1])


def test_the_loop_plant_carrying_a_tool_is_held_to_xdot_loaded():
    """The plant the simulation swaps in while the gripper holds something
    (LoadedVideoRayPlant) steps eqs 1-4 with the load exactly as RK4 on
    ``xdot_loaded`` does, sinks at the steady speed ``hover_command`` predicts with a
    1 kgf tool, and with nothing held is the unloaded plant."""
    from uhrisim.dynamics.plants import VideoRayPlant, carrying

    load = tool_of(1.0)
    base = VideoRayPlant(PAPER, 1 / 60)
    plant = carrying(base, load)
    x0 = np.array([0.0, 0.0, 5.0, 0.3, 0.2, 0.0, 0.1, 0.05])
    u = np.array([40.0, 60.0, PAPER.input_limit])
    x, reference = x0, x0
    n = base.integrator.substeps
    for _ in range(60):
        x = plant.step(0.0, x, u)
        for _ in range(n):
            reference = rk4_step(loaded_xdot(load), 0.0, reference, u, PAPER, 1 / 60 / n)
    np.testing.assert_allclose(x, reference, rtol=1e-12, atol=1e-12)
    still = np.array([0.0, 0.0, 5.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    for _ in range(1800):
        still = plant.step(0.0, still, np.array([0.0, 0.0, PAPER.input_limit]))
    assert still[6] == pytest.approx(cl.hover_command(PAPER, load).steady_heave, rel=1e-4)
    empty = carrying(base, None)
    np.testing.assert_array_equal(empty.step(0.0, x0, u), base.step(0.0, x0, u))


def test_the_load_feed_forward_holds_depth_where_the_p_loop_sags():
    """The paper's P depth loop (K_d 50) holding a 3.11 N tool settles W / (K_d c_T) =
    2.33 m below the ordered depth; with the hover command fed forward
    (VideoRayPController.held_load_input, the assistant's ROV) it holds the ordered
    depth; with nothing held the feed-forward is 0 and the inputs are the paper's."""
    from uhrisim.control.videoray_p import GAIN_PRESETS, VideoRayPController
    from uhrisim.dynamics.plants import VideoRayPlant, carrying

    load = tool_of(3.11 / GRAVITY)
    plant = carrying(VideoRayPlant(PAPER, 1 / 60), load)
    paper = VideoRayPController(GAIN_PRESETS["mission"], PAPER)
    fed = paper.holding(PAPER, load)
    assert fed.held_load_input == cl.hover_command(PAPER, load).command
    settled = {}
    for name, controller in (("paper", paper), ("fed", fed)):
        x = np.array([0.0, 0.0, 5.0, 0.0, 0.0, 0.0, 0.0, 0.0])
        for _ in range(1800):
            x = plant.step(0.0, x, controller.inputs(x, 0.0, 0.0, 5.0))
        settled[name] = x[2] - 5.0
    sag = load.in_water_weight / (50.0 * PAPER.ct_vertical_linear)
    assert sag == pytest.approx(2.33, abs=0.01)
    assert settled["paper"] == pytest.approx(sag, rel=0.02)
    assert abs(settled["fed"]) < 1e-3
    x = np.array([1.0, 2.0, 4.0, 0.3, 0.2, 0.0, 0.1, 0.05])
    np.testing.assert_array_equal(
        VideoRayPController(GAIN_PRESETS["mission"], PAPER, held_load_input=0.0).inputs(
            x, 30.0, 0.5, 5.0), paper.inputs(x, 30.0, 0.5, 5.0))


BAG = (0.35, 0.25, 0.10)  # the folded lift bag, m (world/tools.py)


@pytest.mark.parametrize("params", [PAPER, QUADRATIC], ids=["linear", "quadratic"])
def test_holding_a_load_the_rov_makes_the_speed_it_is_ordered(params):
    """The speed feed-forward of a controller holding a load balances the loaded vehicle's
    drag, so the P speed loop settles at the ordered 0.2 m/s (the assistant's cruise with
    the lift bag); with the empty vehicle's feed-forward it settled well short (0.114 m/s
    in the assisted salvage). Letting go, the controller is the empty vehicle's again."""
    from uhrisim.control.videoray_p import GAIN_PRESETS, VideoRayPController
    from uhrisim.dynamics.plants import VideoRayPlant, carrying
    from uhrisim.world.tools import make_tool

    bag = make_tool("lift_bag", "bag", 1.5)
    load = cl.CarriedLoad(bag.hydro, GRIPPER, cl.box_projected_areas(BAG, np.eye(3)))
    plant = carrying(VideoRayPlant(params, 1 / 60), load)
    empty = VideoRayPController(GAIN_PRESETS["mission"], params)
    settled = {}
    for name, controller in (("empty", empty), ("holding", empty.holding(params, load))):
        x = np.array([0.0, 0.0, 5.0, 0.0, 0.0, 0.0, 0.0, 0.0])
        for _ in range(3600):  # 60 s: many time constants m11' / (2 Xuu' u)
            x = plant.step(0.0, x, controller.inputs(x, 0.0, 0.2, 5.0))
        settled[name] = x[4]
    assert settled["holding"] == pytest.approx(0.2, abs=1e-4)
    assert settled["empty"] < 0.18
    assert empty.holding(params, load).holding(params, None) == empty


def test_a_box_shows_each_axis_the_shadow_of_its_faces():
    """box_projected_areas against the area of the convex hull of the box's corners
    projected along each axis (scipy), for the box square and turned at random."""
    from scipy.spatial import ConvexHull

    from uhrisim.core.frames import rotation_zyx

    assert cl.box_projected_areas(BAG, np.eye(3)) == pytest.approx(
        (0.25 * 0.10, 0.35 * 0.10, 0.35 * 0.25))
    rng = np.random.default_rng(3)
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) \
        * 0.5 * np.array(BAG)
    for _ in range(5):
        rotation = rotation_zyx(*rng.uniform(-math.pi, math.pi, 3))
        turned = corners @ rotation.T
        areas = cl.box_projected_areas(BAG, rotation)
        for axis in range(3):
            shadow = ConvexHull(np.delete(turned, axis, axis=1)).volume  # 2-D: the area
            assert areas[axis] == pytest.approx(shadow, rel=1e-9)


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_the_bag_falls_at_the_terminal_speed_of_the_face_across_each_axis(axis):
    """Its own weight pulling it along one axis at a time (held square), the drag the
    vehicle gets from it (drag_frd) brings it to sqrt(2 W / (rho C_d A)), A the face
    across that axis (b c, a c, a b of its sides a × b × c): integrated with RK4 from
    rest, within 5 %. Towed edge-on (x) it is 3.5 times less draggy than face-on."""
    hydro = Hydro(1.5, 1.5 / 1300.0, 1.2, BAG[0] * BAG[1])  # the scenario's 50 L bag
    load = cl.CarriedLoad(hydro, GRIPPER, cl.box_projected_areas(BAG, np.eye(3)))
    drag = load.drag_frd()[axis]
    weight, inertia = load.in_water_weight, load.rigid_and_added_mass

    def accel(t, v, u, p):
        return (weight - drag * v * np.abs(v)) / inertia

    v = np.zeros(1)
    for _ in range(3000):  # 30 s
        v = rk4_step(accel, 0.0, v, None, None, 0.01)
    face = [BAG[1] * BAG[2], BAG[0] * BAG[2], BAG[0] * BAG[1]][axis]
    known = math.sqrt(2.0 * weight / (WATER_DENSITY * 1.2 * face))
    assert float(v[0]) == pytest.approx(known, rel=0.05)
    loaded = cl.loaded_params(PAPER, load)
    assert (PAPER.Xuu - loaded.Xuu, PAPER.Zww - loaded.Zww) == pytest.approx(
        (load.drag_frd()[0], load.drag_frd()[2]))
    assert load.drag_frd()[2] / load.drag_frd()[0] == pytest.approx(3.5)


def test_areas_must_be_positive():
    from uhrisim.core.errors import ConfigError

    with pytest.raises(ConfigError, match="areas_frd"):
        cl.CarriedLoad(Hydro(1.0, 1e-3, 1.2, 0.01), GRIPPER, (0.01, -0.01, 0.01))
