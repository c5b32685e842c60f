"""The sonar-only trail over full runs: 3 seeds × 10 simulated minutes of the paper's
mission (``track_and_trail_sonar.yaml``) and of its cluttered variant, checked against
issue 15's bands, with a summary figure.

    uhrisim figure sonar-trail --out OUT

writes ``OUT/<scenario>_seed<k>/`` (each run's recording, metrics and figures),
``OUT/sonar_trail_summary.json`` (each run's figures and which bands it meets) and
``OUT/sonar_trail.png``. Bands (issue 15): the paper's mission — acquired, trail range
error RMS ≤ 0.6 m, bearing error RMS ≤ 20°, minimum separation ≥ 1 m, no collision,
diver held by a confirmed track ≥ 95 % of the time; the cluttered variant — held ≥ 85 %,
≤ 1 identity switch per 10 minutes (and no collision).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from uhrisim.app.runner import run_scenario, strict_json
from uhrisim.scenario.shipped import shipped_scenario
from uhrisim.viz.figures import save_figure, subplots

SCENARIOS = ("track_and_trail_sonar", "track_and_trail_sonar_clutter")
SEEDS = (1, 2, 3)
DURATION_S = 600.0


def bands(scenario: str, m: dict[str, Any], duration: float) -> dict[str, bool]:
    """Which of the issue's bands a run's metrics meet."""
    p = m["perception"]
    if scenario.endswith("clutter"):
        return {"held_ge_85pct": (p["held_pct"] or 0.0) >= 85.0,
                "id_switches_le_1_per_10min": p["identity_switches"] <= duration / 600.0,
                "no_collision": m["collisions"] == 0}
    return {"acquired": bool(m["acquired"]),
            "range_rms_le_0.6m": (m["range_error_m"]["rms"] or 1e9) <= 0.6,
            "bearing_rms_le_20deg": (m["bearing_error_deg"]["rms"] or 1e9) <= 20.0,
            "min_separation_ge_1m": m["min_separation_m"] >= 1.0,
            "no_collision": m["collisions"] == 0,
            "held_ge_95pct": (p["held_pct"] or 0.0) >= 95.0}


def summarise(scenario: str, seed: int, m: dict[str, Any], duration: float) -> dict[str, Any]:
    p = m["perception"]
    checks = bands(scenario, m, duration)
    return {"scenario": scenario, "seed": seed, "simulated_s": m["simulated_s"],
            "real_time_factor": m["real_time_factor"], "acquired": m["acquired"],
            "time_to_acquire_s": m["time_to_acquire_s"],
            "range_error_rms_m": m["range_error_m"]["rms"],
            "bearing_error_rms_deg": m["bearing_error_deg"]["rms"],
            "min_separation_m": m["min_separation_m"], "collisions": m["collisions"],
            "held_pct": p["held_pct"], "identity_switches": p["identity_switches"],
            "track_error_rms_m": p["track_error_m"]["rms"],
            "detection_precision": p["detection_precision"],
            "detection_recall_target": p["detection_recall_target"],
            "false_diver_tracks_per_min": p["false_diver_tracks_per_min"],
            "clutter_tracks_per_min": p["clutter_tracks_per_min"],
            "bands": checks, "meets_bands": all(checks.values())}


def plot(rows: list[dict[str, Any]], path: Path) -> Path:
    """Held %, trail range RMS and bearing RMS of every run against the bands."""
    fig, axes = subplots(1, 3, figsize=(12, 3.8))
    labels = [f"{'clutter' if r['scenario'].endswith('clutter') else 'paper'} s{r['seed']}"
              for r in rows]
    colours = ["tab:orange" if r["scenario"].endswith("clutter") else "tab:blue" for r in rows]
    for ax, key, title, band in (
            (axes[0], "held_pct", "diver held by a confirmed track (%)", (95.0, 85.0)),
            (axes[1], "range_error_rms_m", "trail range error RMS (m)", (0.6,)),
            (axes[2], "bearing_error_rms_deg", "trail bearing error RMS (deg)", (20.0,))):
        ax.bar(range(len(rows)), [r[key] or 0.0 for r in rows], color=colours)
        for b in band:
            ax.axhline(b, color="k", ls="--", lw=0.8)
        ax.set_xticks(range(len(rows)), labels, rotation=45, ha="right", fontsize=8)
        ax.set_title(title, fontsize=9)
        ax.grid(True, axis="y", alpha=0.4)
    fig.suptitle("Sonar-only trail: paper's mission (blue) and cluttered variant (orange); "
                 "dashed: issue 15 bands", fontsize=10)
    return save_figure(fig, path)


def make_sonar_trail(out_dir: Path, duration: float = DURATION_S,
                     seeds: tuple[int, ...] = SEEDS,
                     progress: Callable[[float, float], None] | None = None) -> list[Path]:
    """Run every scenario and seed, write the summary and the figure (module docstring).
    ``progress(simulated s done, simulated s in all)`` as the missions run."""
    out_dir.mkdir(parents=True, exist_ok=True)
    rows = []
    missions = [(scenario, seed) for scenario in SCENARIOS for seed in seeds]
    total = duration * len(missions)
    for done, (scenario, seed) in enumerate(missions):
        def mission_progress(t: float, before: float = done * duration) -> None:
            if progress is not None:
                progress(before + t, total)

        result = run_scenario(shipped_scenario(f"{scenario}.yaml"),
                              out_dir / f"{scenario}_seed{seed}", duration=duration,
                              seed=seed, progress=mission_progress)
        assert result.metrics is not None
        rows.append(summarise(scenario, seed, result.metrics, duration))
    summary = out_dir / "sonar_trail_summary.json"
    summary.write_text(json.dumps(strict_json({"duration_s": duration, "runs": rows,
                                               "all_meet_bands": all(r["meets_bands"]
                                                                     for r in rows)}),
                                  indent=2) + "\n")
    return [summary, plot(rows, out_dir / "sonar_trail.png")]
