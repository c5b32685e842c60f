"""The assisted salvage against the diver alone (issue 26; docs/hri.md, "The assisted
salvage, measured").

Runs ``salvage_team_diver_alone.yaml`` and ``salvage_team_assisted.yaml`` (seeds 1–3 in
clear water, Jerlov I) and the assisted one in coastal 9C water (seeds 1–2; its camera's water
replaced, nothing else), each until 20 s after the diver's orders end (done, or one
failed: the rest are not done), and tabulates what the
issue asks of them: the diver's orders done, the task's completion time (the end of his
last order), collisions, the ROV's closest approach to his body and head against its
guards, the signals per channel (issued / recognized / missed / false) with the
hand-overs, and how often the ROV asked "say again?" and the diver repeated a signal.

    python -m uhrisim.experiments.assisted_salvage OUT [--cases alone I:1 I:2 I:3 9C:1 9C:2]
                                                       [--no-sonar]

writes ``OUT/<case>.json`` (the assistant's metrics.json section, or the diver's steps
alone) and prints the table; ``uhrisim figure assisted-salvage`` runs every case and
writes ``assisted_salvage.json`` (about 10 CPU minutes a case on one core).
"""

from __future__ import annotations

import argparse
import json
import re
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from uhrisim.scenario.load import load_scenario
from uhrisim.scenario.shipped import shipped_scenario
from uhrisim.sim.simulation import Simulation

CASES = ("alone", "I:1", "I:2", "I:3", "9C:1", "9C:2")
CLEAR_WATER = "water: {jerlov: I}"
#: a run goes on this long (s) after the diver's last order ends: the ROV's last moves
AFTER_THE_END_S = 20.0


def run_case(case: str, out_dir: Path, progress: Callable[[float], None] | None = None,
             sonar: bool = True) -> dict[str, Any]:
    """Run one case — ``alone`` or ``<water>:<seed>`` of the assisted scenario — until
    ``AFTER_THE_END_S`` after the diver's orders end (done or failed; at most the
    scenario's duration), and write ``out_dir/<case>.json``. ``sonar=False`` leaves the
    ROV's sonar out (about 40 % of the run's time; its decisions do not use it)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    if case == "alone":
        path, seed = shipped_scenario("salvage_team_diver_alone"), None
    else:
        water, seed_text = case.split(":")
        path, seed = shipped_scenario("salvage_team_assisted"), int(seed_text)
        text = path.read_text()
        if CLEAR_WATER not in text:
            raise ValueError(f"{path}: no '{CLEAR_WATER}' to replace")
        text = text.replace(CLEAR_WATER, f"water: {{jerlov: {water}}}")
        if not sonar:
            text = re.sub(r"\n\s*- \{type: sonar[^}]*\}", "", text)
        path = out_dir / f"salvage_team_assisted_{water}{'' if sonar else '_no_sonar'}.yaml"
        path.write_text(text)
    start = time.process_time()
    sim = Simulation(load_scenario(path), seed=seed)
    executor = sim.team.divers["diver"].executor  # type: ignore[union-attr]
    sim.run(progress=progress, should_stop=lambda: executor.finished and bool(
        executor.steps) and sim.t >= (executor.steps[-1].ended or 0.0) + AFTER_THE_END_S)
    steps = executor.steps
    done = executor.finished and not executor.failed
    result: dict[str, Any] = {
        "case": case,
        "scenario": path.name,
        "sonar": sonar,
        "seed": sim.scenario.seed if seed is None else seed,
        "task_completion_s": round(steps[-1].ended, 3) if done and steps else None,
        "orders": {"done": sum(s.outcome == "done" for s in steps),
                   "failed": sum(s.outcome == "failed" for s in steps),
                   "of": len(executor.orders)},
        "simulated_s": round(sim.t, 2),
        "collisions": sim.collisions,
        "cpu_s": round(time.process_time() - start, 1),
    }
    if sim.assistance is not None:
        result["assistant"] = sim.assistance.summary()["assistant"]
        result["events"] = [f"{e.t:.1f} {e.detail}" for e in sim.events_log
                            if e.kind in ("assistant", "collision")]
    (out_dir / f"{case.replace(':', '_')}.json").write_text(json.dumps(result, indent=1) + "\n")
    return result


def _read(metrics: dict[str, Any], channel: str) -> str:
    c = metrics["signals"].get(channel, {})
    return f"{c.get('recognized', 0)}/{c.get('issued', 0)} ({c.get('false', 0)} false)"


def table(results: list[dict[str, Any]]) -> str:
    """The cases as docs/hri.md's table rows."""
    rows = ["| case | orders done | task completion | collisions | closest body / head "
            "(guards) | markers read | gestures read | hand-overs | asked again / repeats |",
            "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in results:
        a = next(iter(r.get("assistant", {}).values()), None)
        o = r["orders"]
        done = f"{o['done']} of {o['of']}" + (f", {o['failed']} failed" if o["failed"] else "")
        time_s = "—" if r["task_completion_s"] is None else f"{r['task_completion_s']:.1f} s"
        if a is None:
            rows.append(f"| {r['case']} | {done} | {time_s} | {r['collisions']} | — | — | — "
                        "| — | — |")
            continue
        sep, h = a["min_separation_m"], a["handovers"]
        rows.append(f"| {r['case']} | {done} | {time_s} | {r['collisions']} | "
                    f"{sep['body']:.2f} / {sep['head']:.2f} m ({sep['body_guard']} / "
                    f"{sep['head_guard']}) | {_read(a, 'marker')} | {_read(a, 'gesture')} | "
                    f"{h['succeeded']}/{h['attempted']} | {a['asked_again']} / "
                    f"{a['signals_repeated']} |")
    return "\n".join(rows)


def make_assisted_salvage(out_dir: Path) -> list[Path]:
    """Every case (module docstring): ``assisted_salvage.json`` and the table in
    ``assisted_salvage.md``."""
    out = Path(out_dir)
    results = [run_case(case, out / "cases") for case in CASES]
    data, text = out / "assisted_salvage.json", out / "assisted_salvage.md"
    data.write_text(json.dumps(results, indent=1) + "\n")
    text.write_text(table(results) + "\n")
    return [data, text]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--cases", nargs="+", default=list(CASES),
                        help="alone, or <water>:<seed> of the assisted scenario")
    parser.add_argument("--no-sonar", action="store_true",
                        help="leave the ROV's sonar out (quicker; the decisions do not use it)")
    args = parser.parse_args(argv)
    results = [run_case(case, args.out, sonar=not args.no_sonar) for case in args.cases]
    print(table(results))


if __name__ == "__main__":
    main()
