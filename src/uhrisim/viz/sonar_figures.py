"""Sonar figures of the paper's scenes — the pier (Figs 12-14) and the torus (Figs 15-16) —
and of the test tank (``scenarios/sonar_tank.yaml``, :func:`make_sonar_tank`: fan images,
label images and their statistics against real frames), for any preset; the preset
gallery (:func:`make_sonar_presets`), each preset's fan drawn as its maker's viewer
draws one (:func:`vendor_fan`); the figure of ``uhrisim sonar-compare``.

Each ``make_*`` writes, into ``out_dir``:

* ``*_scene_top.png`` — the 3-D scene seen from above (sea-floor depth, structures, the
  sonar and its 45° fan, the ray hits of one ping);
* ``*_2013.png`` — the paper's image (2013 mode: points ×10 px/m, apex top-left, blur,
  white fan boundary lines);
* ``*_fan.png`` — the physically formed fan image (apex bottom-centre, colour-mapped);
* ``*_labels.png`` — which object produced each fan pixel's strongest return;
* ``*_panel.png`` — polar image, fan with metric axes and the 2013 image side by side;
* ``*_polar.npy`` — the polar image (n_bins, n_beams) float32, display scale 0…1.

Axes: the top view shows east to the right and north up (metres, NED).
"""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
from matplotlib.collections import PolyCollection

from uhrisim.core.rng import component_rng
from uhrisim.sensors.sonar import PRESETS, ImagingSonar, SonarConfig, SonarPing, get_preset
from uhrisim.sensors.sonar.stats import (
    GEOMETRY_FILE,
    image_stats,
    object_label_image,
    write_fan_geometry,
)
from uhrisim.viz.fan_plot import FanView, draw_fan, nice_step
from uhrisim.viz.figures import save_figure, subplots

SEED = 2013


#: The preset of the paper's figures (Table I).
PAPER_PRESET = "P900-45"


def scene_pings(paper, pose_name: str, range_max_m: float,
                preset: str = PAPER_PRESET) -> tuple[SonarPing, SonarPing]:  # fmt: skip
    """(physical ping, 2013-mode ping) of ``preset`` at the scene's pose ``pose_name``,
    out to ``range_max_m`` or the preset's maximum range, whichever is nearer."""
    pose = paper.sonar_poses[pose_name]
    rc = paper.scene.raycaster("embree")
    common = dict(
        preset=preset, tilt_deg=pose.tilt_deg, mount_position_frd=(0.0, 0.0, 0.0),
        range_max_m=min(range_max_m, get_preset(preset).max_range_m),
    )  # fmt: skip
    phys = ImagingSonar(
        SonarConfig(colormap="bone", fan_size_px=600, labels=True, **common),
        component_rng(SEED, "figure/sonar"),
    ).ping(rc, pose.position_ned, pose.rotation, 0.0)
    paper_mode = ImagingSonar(
        SonarConfig(mode="2013", rays_per_beam=32, **common), component_rng(SEED, "figure/2013")
    ).ping(rc, pose.position_ned, pose.rotation, 0.0)
    return phys, paper_mode


def _top_view(paper, ping: SonarPing, range_max_m: float, title: str, path: Path) -> None:
    scene = paper.scene
    fig, ax = subplots(figsize=(7.0, 7.0))
    floor = scene.seafloor
    if floor is not None:
        im = ax.pcolormesh(floor.east, floor.north, floor.depth, cmap="Blues", shading="auto")
        fig.colorbar(im, ax=ax, shrink=0.7, label="sea-floor depth (m)")
    seen: set[str] = set()
    for obj in scene.static_objects:
        if obj.label == "seafloor":
            continue
        name = obj.label if obj.label not in seen else None
        seen.add(obj.label)
        tri = obj.mesh.triangles[:, :, :2]  # (n, 3, [north, east])
        polys = tri[:, :, ::-1]  # plot east → x, north → y
        ax.add_collection(PolyCollection(polys, facecolor="0.35", edgecolor="none", label=name))
    p = ping.position_ned
    axis = ping.rotation_ned_from_sonar[:, 0]
    heading = math.atan2(axis[1], axis[0])
    half = ping.fan_half_fov_rad
    arc = np.linspace(heading - half, heading + half, 50)
    fan_n = np.concatenate([[p[0]], p[0] + range_max_m * np.cos(arc), [p[0]]])
    fan_e = np.concatenate([[p[1]], p[1] + range_max_m * np.sin(arc), [p[1]]])
    ax.plot(fan_e, fan_n, color="tab:orange", lw=1.2, label="sonar fan")
    hits = ping.hit_points_ned[:: max(1, len(ping.hit_points_ned) // 4000)]
    ax.scatter(hits[:, 1], hits[:, 0], s=0.5, color="tab:red", alpha=0.5, label="ray hits")
    ax.plot(p[1], p[0], "k^", ms=8, label="sonar")
    bounds = scene.bounds()
    ax.set_xlim(max(bounds[0, 1], p[1] - range_max_m), min(bounds[1, 1], p[1] + range_max_m))
    ax.set_ylim(max(bounds[0, 0], p[0] - 2.0), min(bounds[1, 0], p[0] + range_max_m + 2.0))
    ax.set_aspect("equal")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_title(title)
    ax.legend(loc="lower right", fontsize=8)
    save_figure(fig, path, dpi=110)


def _label_image(ping: SonarPing, names: list[str]) -> np.ndarray:
    colours = np.array(
        [[40, 90, 160], [40, 200, 240], [80, 220, 80], [230, 120, 40], [200, 60, 200]],
        dtype=np.uint8,
    )  # BGR per label id (cycled)
    out = np.zeros((*ping.label_fan.shape, 3), dtype=np.uint8)
    lab = ping.label_fan
    hit = lab >= 0
    out[hit] = colours[lab[hit] % len(colours)]
    for i, name in enumerate(names):
        cv2.putText(out, name, (8, 20 + 18 * i), cv2.FONT_HERSHEY_SIMPLEX, 0.5,
                    tuple(int(c) for c in colours[i % len(colours)]), 1)  # fmt: skip
    return out


def _panel(phys: SonarPing, paper_mode: SonarPing, title: str, path: Path) -> None:
    fig, axes = subplots(1, 3, figsize=(15.0, 5.5), layout="constrained")
    r = phys.bin_ranges_m
    th = np.degrees(phys.beam_angles_rad)
    polar = axes[0].imshow(
        phys.polar, origin="lower", aspect="auto", cmap="bone", vmin=0.0, vmax=1.0,
        extent=(th[0], th[-1], r[0], r[-1]),
    )  # fmt: skip
    fig.colorbar(polar, ax=axes[0], shrink=0.85, label="display intensity (0-1, linear in dB)")
    axes[0].set_xlabel("beam angle (deg, + starboard)")
    axes[0].set_ylabel("range (m)")
    axes[0].set_title("polar image (beams × range bins)")
    draw_fan(axes[1], FanView.of_ping(phys), cmap="bone")
    axes[1].set_title("physical fan (apex bottom-centre)")
    axes[2].imshow(paper_mode.fan_u8, cmap="gray")
    axes[2].set_xlabel("column (px, 10 px/m)")
    axes[2].set_ylabel("row (px)")
    axes[2].set_title("2013 mode (apex top-left)")
    fig.suptitle(title)
    save_figure(fig, path, dpi=100)


def _write(paper, pose_name: str, range_max_m: float, stem: str, title: str,
           out_dir: Path, preset: str = PAPER_PRESET) -> list[Path]:  # fmt: skip
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    phys, paper_mode = scene_pings(paper, pose_name, range_max_m, preset)
    if preset != PAPER_PRESET:
        title = f"{title}, {preset}"
    paths = [
        out / f"{stem}_scene_top.png",
        out / f"{stem}_2013.png",
        out / f"{stem}_fan_colour.png",
        out / f"{stem}_labels_colour.png",
        out / f"{stem}_panel.png",
        out / f"{stem}_polar.npy",
        out / f"{stem}_fan.png",
        out / f"{stem}_labels.png",
        out / GEOMETRY_FILE,
    ]
    _top_view(paper, phys, float(phys.bin_ranges_m[-1]), f"{title}: scene from above", paths[0])
    cv2.imwrite(str(paths[1]), paper_mode.fan_u8)
    cv2.imwrite(str(paths[2]), phys.fan_rgb if phys.fan_rgb is not None else phys.fan_u8)
    cv2.imwrite(str(paths[3]), _label_image(phys, paper.scene.labels))
    _panel(phys, paper_mode, title, paths[4])
    np.save(paths[5], phys.polar)
    # the pair uhrisim sonar-stats and sonar-compare read: 8-bit fan, 16-bit object labels
    cv2.imwrite(str(paths[6]), phys.fan_u8)
    cv2.imwrite(str(paths[7]), object_label_image(phys.label_fan,
                                                  {paper.scene.label_id("seafloor")}))
    write_fan_geometry(out, phys)
    return paths


def make_sonar_pier(out_dir: Path, preset: str = PAPER_PRESET) -> list[Path]:
    """Pier support beams over bathymetry (paper Figs 12-14) seen by ``preset`` (the
    paper's P900-45 by default; 30 m, or the preset's maximum range); see the module
    docstring."""
    from uhrisim.world.paper_scenes import pier_scene

    return _write(pier_scene(), "approach", 30.0, "sonar_pier", "Pier (paper Figs 12-14)",
                  out_dir, preset)  # fmt: skip


def make_sonar_torus(out_dir: Path, preset: str = PAPER_PRESET) -> list[Path]:
    """Torus on the sea floor (paper Figs 15-16) seen by ``preset``; see the module
    docstring."""
    from uhrisim.world.paper_scenes import torus_scene

    return _write(torus_scene(), "front", 20.0, "sonar_torus", "Torus (paper Figs 15-16)",
                  out_dir, preset)  # fmt: skip


#: Look-alike palettes (matplotlib colour maps) for each maker's fans in
#: :func:`vendor_fan`: our choice, as the makers do not publish their viewers' defaults.
VENDOR_PALETTES = {"P900": "copper", "M900": "copper", "ARIS": "gray", "M750d": "inferno",
                   "M1200d": "inferno", "Gemini": "bone"}  # fmt: skip


def vendor_fan(ping: SonarPing, fan_mask: np.ndarray, preset: str) -> np.ndarray:
    """``ping``'s fan drawn as a maker's viewer draws one: the 8-bit fan through the
    maker's palette (:data:`VENDOR_PALETTES`), black outside ``fan_mask``, range arcs at a
    1-2-5 step with their distances, the fan's edges and bearing lines every 10° or 15°,
    and a caption with the sonar, its frequency and the range. BGR, apex bottom-centre."""
    from matplotlib import colormaps

    spec = get_preset(preset)
    family = next(k for k in VENDOR_PALETTES if preset.startswith(k))
    lut = (colormaps[VENDOR_PALETTES[family]](np.linspace(0, 1, 256))[:, 2::-1] * 255)
    image = lut.astype(np.uint8)[ping.fan_u8]
    image[~fan_mask] = 0
    scale = ping.fan_px_per_m
    col0, row0 = ping.fan_apex_px
    apex = (round(col0), round(row0))
    half = math.degrees(ping.fan_half_fov_rad)
    far = float(ping.bin_ranges_m[-1])
    grey, font = (150, 150, 150), cv2.FONT_HERSHEY_SIMPLEX
    step = nice_step(far)
    r = step
    while r <= far + 1e-9:
        radius = round(r * scale)
        cv2.ellipse(image, apex, (radius, radius), 0.0, -90.0 - half, -90.0 + half, grey, 1,
                    cv2.LINE_AA)  # fmt: skip
        tip = (apex[0] + round(radius * math.sin(math.radians(half))) + 3,
               apex[1] - round(radius * math.cos(math.radians(half))))  # fmt: skip
        cv2.putText(image, f"{r:g} m", tip, font, 0.3, grey, 1, cv2.LINE_AA)
        r += step
    tick = 15.0 if half > 30.0 else 10.0
    angle = -math.floor(half / tick) * tick
    for a in sorted({-half, half, *np.arange(angle, half + 1e-9, tick)}):
        end = (apex[0] + round(far * scale * math.sin(math.radians(a))),
               apex[1] - round(far * scale * math.cos(math.radians(a))))  # fmt: skip
        cv2.line(image, apex, end, grey, 1, cv2.LINE_AA)
    caption = f"{preset}  {spec.frequency_hz / 1e6:g} MHz  {far:.0f} m"
    cv2.putText(image, caption, (4, 12), font, 0.35, (230, 230, 230), 1, cv2.LINE_AA)
    return image


def make_sonar_presets(out_dir: Path, n_frames: int = 3) -> list[Path]:
    """Every preset in the same test tank (``scenarios/sonar_tank.yaml``: 10 m, tilted
    20°, five debris objects): ``tank_<preset>.jpg``, its first frame as the maker's viewer
    draws it (:func:`vendor_fan`, 320 px on its longer side: the gallery of
    ``docs/sonar.md``), and
    ``presets_tank.json``: per preset the statistics of its ``n_frames`` frames."""
    import json

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths, table = [], {}
    for name in PRESETS:
        pings, mask, background = tank_frames(n_frames, preset=name, fan_width_px=320)
        labels = [object_label_image(p.label_fan, background) for p in pings]
        stats = image_stats([p.fan_u8 for p in pings], labels, mask)
        keys = ("median_background_cv", "median_object_ratio", "frames_with_objects",
                "max_zero_fraction")  # fmt: skip
        table[name] = {k: stats[k] for k in keys}
        path = out / f"tank_{name}.jpg"
        cv2.imwrite(str(path), vendor_fan(pings[0], mask, name), [cv2.IMWRITE_JPEG_QUALITY, 88])
        paths.append(path)
    summary = out / "presets_tank.json"
    summary.write_text(json.dumps(table, indent=1))
    return [*paths, summary]


#: Real tank frames (issue 14; ``docs/sonar.md``): in-fan background std/mean 0.34–0.50
#: (median ≈ 0.41), objects 1.4–2.4× the background, no exactly-zero in-fan pixels.
REAL_FRAME_BANDS = {
    "median_background_cv": (0.34, 0.50),
    "median_object_ratio": (1.4, 2.4),
    "median_zero_fraction": (0.0, 0.01),
}


def tank_scenario(preset: str | None = None, fan_width_px: int | None = None):
    """``scenarios/sonar_tank.yaml`` (a ScenarioFile), its sonar the ``preset`` and its fan
    ``fan_width_px`` wide if given (the scene, mount and 10 m window unchanged)."""
    from uhrisim.scenario.load import ScenarioFile, load_with_lines, validate_data
    from uhrisim.scenario.shipped import shipped_scenario

    path = shipped_scenario("sonar_tank.yaml")
    data, lines = load_with_lines(path.read_text(encoding="utf-8"), str(path))
    if preset is not None:
        get_preset(preset)  # an unknown name fails here, naming the known ones
        data["agents"][0]["sensors"][0]["preset"] = preset
    if fan_width_px is not None:
        data["agents"][0]["sensors"][0]["fan_size_px"] = fan_width_px
    return ScenarioFile(validate_data(data, str(path), lines), path, lines)


def tank_frames(
    n_frames: int = 30, seed: int | None = None, preset: str | None = None,
    fan_width_px: int | None = None,
) -> tuple[list[SonarPing], np.ndarray, set[int]]:  # fmt: skip
    """Run ``scenarios/sonar_tank.yaml`` (with ``preset``'s sonar and a fan
    ``fan_width_px`` wide if given) until its sonar has pinged ``n_frames`` times: (the
    pings, the fan mask, the scene labels of the background — the sea floor)."""
    from uhrisim.sim.hooks import sensor_key
    from uhrisim.sim.simulation import Simulation

    sim = Simulation(tank_scenario(preset, fan_width_px), seed=seed)
    agent = sim.scenario.agents[0].name
    slot = sim.agents[agent].sonars[0]
    key = sensor_key(agent, slot.name)
    pings: list[SonarPing] = []
    while len(pings) < n_frames:
        ping = sim.step().pings.get(key)
        if ping is not None:
            pings.append(ping)
    sonar = slot.sonar
    return pings, sonar.geometry.fan_mask, {sim.scene.label_id("seafloor")}


def make_sonar_tank(out_dir: Path, n_frames: int = 30, preset: str | None = None) -> list[Path]:
    """The test tank with the default image settings (its P900-90, or ``preset``):
    ``tank_NNN_fan.png`` (8-bit fan), ``tank_NNN_labels.png`` (16-bit: 0 background, scene
    label + 1 for objects), ``fan_mask.png``, ``tank_stats.json``
    (:func:`uhrisim.sensors.sonar.stats.image_stats`, the same numbers ``uhrisim
    sonar-stats`` prints for the folder, with the real-frame bands), ``tank_panel.png``
    (three frames, their labels, the range and bearing brightness profiles) and
    ``tank_vendor.png`` (the first frame as the maker's viewer draws it,
    :func:`vendor_fan`)."""
    import json

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    pings, mask, background = tank_frames(n_frames, preset=preset)
    name = preset or "P900-90"
    fans = [p.fan_u8 for p in pings]
    labels = [object_label_image(p.label_fan, background) for p in pings]
    paths: list[Path] = []
    for i, (fan, lab) in enumerate(zip(fans, labels, strict=True)):
        for kind, image in (("fan", fan), ("labels", lab)):
            path = out / f"tank_{i:03d}_{kind}.png"
            cv2.imwrite(str(path), image)
            paths.append(path)
    mask_path = out / "fan_mask.png"
    cv2.imwrite(str(mask_path), mask.astype(np.uint8) * 255)
    stats = image_stats(fans, labels, mask, px_per_m=pings[0].fan_px_per_m)
    stats["preset"] = name
    stats["real_frame_bands"] = REAL_FRAME_BANDS
    stats_path = out / "tank_stats.json"
    stats_path.write_text(json.dumps(stats, indent=1))
    panel = out / "tank_panel.png"
    _tank_panel(pings, labels, stats, panel, name)
    vendor = out / "tank_vendor.png"
    cv2.imwrite(str(vendor), vendor_fan(pings[0], mask, name))
    return [*paths, mask_path, stats_path, panel, vendor, write_fan_geometry(out, pings[0])]


def _tank_panel(pings, labels, stats: dict, path: Path, name: str) -> None:
    fig, axes = subplots(2, 3, figsize=(15.0, 9.5), layout="constrained")
    for k, i in enumerate((0, len(pings) // 2, len(pings) - 1)):
        view = FanView.of_ping(pings[i])
        draw_fan(axes[0, k], view, cmap="gray", grid_colour="tab:olive")
        left, right, bottom, top = view.extent
        axes[0, k].contour(labels[i] > 0, levels=[0.5], colors="tab:red", linewidths=0.6,
                           extent=(left, right, top, bottom), origin="upper")
        axes[0, k].set_title(f"frame {i} (objects outlined)")
    r = np.array(stats["range_profile"]["range_m"], float)
    axes[1, 0].plot(r, np.array(stats["range_profile"]["relative_brightness"], float), "o-")
    axes[1, 0].set_xlabel("range (m)")
    axes[1, 0].set_ylabel("background brightness / mean")
    axes[1, 0].set_title("range profile")
    b = stats["bearing_profile"]
    axes[1, 1].plot(b["bearing_deg"], np.array(b["relative_brightness"], float), "o-")
    axes[1, 1].set_xlabel("bearing (deg, + starboard)")
    axes[1, 1].set_title("bearing profile")
    per = stats["per_frame"]
    axes[1, 2].plot([f["background_cv"] for f in per], label="background std/mean")
    axes[1, 2].plot([f["object_ratio"] for f in per], label="object / background")
    for lo, hi in (REAL_FRAME_BANDS["median_background_cv"],
                   REAL_FRAME_BANDS["median_object_ratio"]):  # fmt: skip
        axes[1, 2].axhspan(lo, hi, color="0.85", zorder=0)
    axes[1, 2].set_xlabel("frame")
    axes[1, 2].set_title("per frame (grey: real tank frames)")
    axes[1, 2].legend(fontsize=8)
    fig.suptitle(
        f"Sonar test tank ({name}, 10 m): background std/mean "
        f"{stats['median_background_cv']:.2f}, object/background "
        f"{stats['median_object_ratio']:.2f}, zero px {stats['median_zero_fraction']:.2%}"
    )
    save_figure(fig, path, dpi=90)


def make_compare_figure(report: dict, curves: dict, path: Path) -> Path:
    """The figure of ``uhrisim sonar-compare`` (:func:`uhrisim.sensors.sonar.compare.
    compare_folders`): REAL against SIM — intensity histograms, LBP texture histograms,
    the speckle's autocorrelation along range and across bearing, the background's
    brightness across the fan and along range, and the verdict of every measure."""
    real, sim = curves["real"], curves["sim"]
    fig, axes = subplots(2, 3, figsize=(16.0, 9.0))
    colours = {"REAL": "tab:blue", "SIM": "tab:orange"}
    pairs = (("REAL", real), ("SIM", sim))
    ax = axes[0, 0]
    for name, stats in pairs:
        ax.plot(np.arange(256), stats.histogram, color=colours[name], label=name)
    ax.set_yscale("log")
    ax.set_xlabel("8-bit level (in-fan pixels)")
    ax.set_ylabel("fraction")
    m = report["measures"]
    ax.set_title(f"intensity: JS {m['js_divergence_bits']['difference']:.3g} bit, "
                 f"EMD {m['emd_grey_levels']['difference']:.3g} levels")  # fmt: skip
    ax.legend()
    ax = axes[0, 1]
    codes = np.arange(10)
    ax.bar(codes - 0.2, real.lbp, 0.4, color=colours["REAL"], label="REAL")
    ax.bar(codes + 0.2, sim.lbp, 0.4, color=colours["SIM"], label="SIM")
    ax.set_xticks(codes, [*(str(c) for c in range(9)), "non-\nuniform"])
    ax.set_xlabel("LBP code (ones of 8 neighbours ≥ centre)")
    ax.set_title(f"texture (LBP): JS {m['lbp_js_divergence_bits']['difference']:.3g} bit")
    ax.legend()
    ax = axes[0, 2]
    for name, stats, units in (("REAL", real, curves["units"]), ("SIM", sim, curves["sim_units"])):
        g = stats.grain
        lags = np.arange(len(g["acf_range"]))
        ax.plot(lags * g["lag_px"] / units["range_px"], g["acf_range"], color=colours[name],
                label=f"{name} along range")  # fmt: skip
        ax.plot(lags * g["lag_deg"] / units["bearing_deg"], g["acf_bearing"], "--",
                color=colours[name], label=f"{name} across bearing")  # fmt: skip
    ax.axhline(0.5, color="0.6", lw=0.8)
    names = curves["unit_names"]
    widths = [m[k].get("real") or 1.0 for k in ("grain_range", "grain_bearing")]
    ax.set_xlim(0, 4 * max(widths))
    ax.set_xlabel(f"lag ({names['range_px']} along range, {names['bearing_deg']} across)")
    ax.set_ylabel("autocorrelation")
    ax.set_title("speckle grain (half maximum = grain width)")
    ax.legend(fontsize=8)
    for ax, key, label in ((axes[1, 0], "bearing", "bearing / half the field of view"),
                           (axes[1, 1], "range", "range / the fan's far range")):  # fmt: skip
        for name, stats in pairs:
            ax.plot(stats.profiles[key + "_centres"], stats.profiles[key], "o-",
                    color=colours[name], label=name)  # fmt: skip
        ax.set_xlabel(label)
        ax.set_ylabel("background brightness / its mean")
        ax.set_title("brightness across the fan" if key == "bearing" else
                     "brightness along range")  # fmt: skip
        ax.legend()
    ax = axes[1, 2]
    ax.set_axis_off()
    rows = [[k, m_["verdict"]] for k, m_ in m.items()]
    table = ax.table(cellText=rows, colLabels=["measure", "verdict"], loc="center",
                     cellLoc="left")  # fmt: skip
    table.scale(1.0, 1.2)
    for (row, _), cell in table.get_celld().items():
        if row > 0:
            verdict = rows[row - 1][1]
            cell.set_facecolor({"match": "#d9f2d9", "close": "#fff2cc",
                                "differs": "#f8d0d0"}.get(verdict, "white"))  # fmt: skip
    v = report["verdicts"]
    fig.suptitle(f"sonar-compare: REAL {report['real']} vs SIM {report['sim']} — "
                 f"{v['match']} match, {v['close']} close, {v['differs']} differ")  # fmt: skip
    return save_figure(fig, path, dpi=90)
