"""Parameter sweeps: one base scenario, values by dotted path, seeds; one Ray task a run.

A sweep file (YAML; paths beside it)::

    scenario: track_and_trail.yaml      # the base scenario
    name: heading gains                 # the summary figure's title (default: file name)
    set: {duration: 60, recording.enabled: false}   # the same for every run
    grid:                               # every combination (Cartesian product)
      agents.videoray.controller.heading: [0.5, 1.0, 2.0]
      metrics.range: [2.0, 3.0]
    list:                               # explicit points, crossed with the grid
      - {world.water.temperature_c: 5}
      - {world.water.temperature_c: 25}
    random: {count: 8, seed: 3, parameters: {contacts_noise: ...}}   # crossed too
    seeds: [1, 2, 3]                    # or {count: 10, start: 0}; default: the scenario's
    raycast_sensors: true               # run the sonars and cameras (images cost time)
    figures: true                       # each run's figures (seconds of matplotlib a run)

Each run is the base scenario with its values applied, validated, and identified by the
SHA-256 of its resolved scenario (every default filled in) and the ray-cast sensors switch: its
folder is ``runs/<first 12 hex digits>``. A run whose folder holds a complete
``metrics.json`` (``"completed": true``) is not run again, so a killed sweep restarts where
it stopped. A run that fails (a value the schema refuses, a build error, a numerical
blow-up) is a row with ``status = failed`` and its one-line error; the others go on.
Outputs: ``results.parquet`` and ``results.csv`` (one row per run: parameters, seed,
status, error, every metric flattened as ``range_error_m.rms``), ``summary.png``. The
``figures`` switch changes no result, so it is not part of a run's identity.
"""

from __future__ import annotations

import copy
import csv
import hashlib
import itertools
import json
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any

from pydantic import Field, PositiveFloat, field_validator

from uhrisim.batch.cluster import check_address, ray_session, run_tasks
from uhrisim.batch.params import Draw, apply_path, check_path, read_yaml
from uhrisim.core.errors import ConfigError, UhrisimError, first_line
from uhrisim.core.rng import component_rng
from uhrisim.scenario.load import ScenarioFile, validate_data
from uhrisim.scenario.schema import Strict
from uhrisim.scenario.yaml_lines import line_of

RUNS_DIR = "runs"
#: Metrics of metrics.json that repeat a column the table already has.
_REPEATED = ("scenario", "seed")


class RandomSection(Strict):
    """``count`` points, each value drawn from its :class:`Draw` by ``seed``'s stream."""

    count: Annotated[int, Field(ge=1)]
    seed: Annotated[int, Field(ge=0)] = 0
    parameters: dict[str, Draw]


class SeedRange(Strict):
    count: Annotated[int, Field(ge=1)]
    start: Annotated[int, Field(ge=0)] = 0


class SweepFile(Strict):
    """A sweep file (see the module docstring)."""

    scenario: str
    name: str | None = None
    set: dict[str, Any] = Field(default_factory=dict)
    grid: dict[str, tuple[Any, ...]] | None = None
    points: tuple[dict[str, Any], ...] | None = Field(None, alias="list")
    random: RandomSection | None = None
    seeds: tuple[Annotated[int, Field(ge=0)], ...] | SeedRange | None = None
    raycast_sensors: bool = True
    figures: bool = True
    duration: PositiveFloat | None = None

    @field_validator("grid")
    @classmethod
    def _grid_values(cls, grid: dict[str, tuple[Any, ...]] | None) -> Any:
        if grid is not None and not grid:
            raise ValueError("the grid is empty: give each parameter a list of values")
        for path, values in (grid or {}).items():
            if not values:
                raise ValueError(f"{path}: an empty list of values gives no runs")
        return grid

    @field_validator("points")
    @classmethod
    def _points(cls, points: tuple[dict[str, Any], ...] | None) -> Any:
        if points is not None and (not points or not all(points)):
            raise ValueError("list: give at least one point, each with at least one value")
        return points


@dataclass(frozen=True)
class PlannedRun:
    """One run of a sweep: its values, seed, scenario data and identity."""

    index: int
    parameters: dict[str, Any]
    seed: int
    data: dict[str, Any]
    run_id: str
    scenario_path: str
    raycast_sensors: bool
    figures: bool = True  # each run's figures (trajectory.png, ...) beside its metrics
    error: str | None = None  # the scenario refuses these values: failed without running


@dataclass
class SweepPlan:
    name: str
    parameters: list[str]
    runs: list[PlannedRun]


@dataclass
class SweepResult:
    """What a sweep produced: one row per run, in plan order, and the files."""

    rows: list[dict[str, Any]]
    skipped: int
    files: list[Path] = field(default_factory=list)
    nodes: dict[str, int] = field(default_factory=dict)  # runs finished per Ray node id
    planned: int = 0  # runs the sweep file plans (more than rows with a --limit)

    @property
    def failed(self) -> int:
        return sum(row["status"] == "failed" for row in self.rows)


def load_sweep(path: str | Path) -> SweepPlan:
    """Read and check a sweep file and plan its runs: every error (an unknown dotted path,
    an empty grid, a missing scenario) is a one-line ConfigError before anything runs."""
    path = Path(path)
    data, lines = read_yaml(path, "sweep")
    sweep: SweepFile = validate_data(data, str(path), lines, model=SweepFile, kind="sweep")
    base_path = (path.parent / sweep.scenario).resolve()
    base, base_lines = read_yaml(base_path, "scenario")
    validate_data(base, str(base_path), base_lines)  # the base itself must be sound

    def where(*key: Any) -> str:
        line = line_of(lines, key)
        return f"{path}:{line}" if line else str(path)

    sections: list[tuple[tuple[Any, ...], str]] = [(("set", p), p) for p in sweep.set]
    sections += [(("grid", p), p) for p in sweep.grid or {}]
    sections += [(("list", i, p), p) for i, point in enumerate(sweep.points or ())
                 for p in point]
    sections += [(("random", "parameters", p), p) for p in
                 (sweep.random.parameters if sweep.random else {})]
    owners: dict[str, str] = {}
    for key, dotted in sections:
        try:
            check_path(dotted, base)
        except ConfigError as error:
            raise ConfigError(str(error), where=where(*key)) from None
        if owners.setdefault(dotted, key[0]) != key[0]:
            raise ConfigError(f"{dotted} is in both {owners[dotted]} and {key[0]}",
                              where=where(*key))
    swept = [p for p, section in owners.items() if section != "set"]
    points = _points(sweep)
    seeds = _seeds(sweep, base)
    runs = [_plan_run(i, point, seed, base, sweep, base_path, str(path))
            for i, (point, seed) in enumerate(itertools.product(points, seeds))]
    return SweepPlan(sweep.name or path.stem, swept, runs)


def _points(sweep: SweepFile) -> list[dict[str, Any]]:
    """Every combination of the grid, crossed with the list points and the random ones."""
    grid = sweep.grid or {}
    grid_points = [dict(zip(grid, values, strict=True))
                   for values in itertools.product(*grid.values())]
    listed = [dict(p) for p in sweep.points] if sweep.points else [{}]
    drawn: list[dict[str, Any]] = [{}]
    if sweep.random is not None:
        rng = component_rng(sweep.random.seed, "sweep/random")
        drawn = [{p: d.sample(rng) for p, d in sweep.random.parameters.items()}
                 for _ in range(sweep.random.count)]
    return [g | li | d for g in grid_points for li in listed for d in drawn]


def _seeds(sweep: SweepFile, base: dict[str, Any]) -> list[int]:
    if sweep.seeds is None:
        return [int(base.get("seed", 0))]
    if isinstance(sweep.seeds, SeedRange):
        return list(range(sweep.seeds.start, sweep.seeds.start + sweep.seeds.count))
    return list(sweep.seeds)


def _plan_run(index: int, point: dict[str, Any], seed: int, base: dict[str, Any],
              sweep: SweepFile, base_path: Path, sweep_path: str) -> PlannedRun:
    data = copy.deepcopy(base)
    for dotted, value in (sweep.set | point).items():
        apply_path(data, dotted, value)
    data["seed"] = seed
    if sweep.duration is not None:
        data["duration"] = sweep.duration
    error = None
    try:
        scenario = validate_data(data, f"{sweep_path} run {index}")
        identity: Any = scenario.model_dump(mode="json")
    except ConfigError as refused:
        error, identity = str(refused), data
    digest = hashlib.sha256(json.dumps(
        {"scenario": identity, "raycast_sensors": sweep.raycast_sensors},
        sort_keys=True, default=str).encode()).hexdigest()
    return PlannedRun(index, point, seed, data, digest[:12], str(base_path), sweep.raycast_sensors,
                      sweep.figures, error)


def completed_metrics(run_dir: Path) -> dict[str, Any] | None:
    """The metrics of a finished run in ``run_dir``; None if it has none, or they are cut
    short or mark the run incomplete."""
    try:
        metrics = json.loads((run_dir / "metrics.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return metrics if isinstance(metrics, dict) and metrics.get("completed") is True else None


def execute_run(task: tuple[PlannedRun, str]) -> dict[str, Any]:
    """Run one planned run into its folder (a Ray task): a row of the results table. Any
    error becomes ``status = failed`` with its one-line message."""
    from uhrisim.app.runner import run_scenario

    run, out = task
    run_dir = run_folder(run, Path(out))
    start = time.perf_counter()
    try:
        scenario = validate_data(run.data, f"run {run.run_id}")
        source = ScenarioFile(scenario, Path(run.scenario_path))
        metrics = run_scenario(source, run_dir, raycast_sensors=run.raycast_sensors,
                               figures=run.figures).metrics or {}
        status, error = "ok", None
    except Exception as failure:
        metrics, status, error = {}, "failed", one_line(failure)
        (run_dir / "error.txt").write_text(error + "\n")
    return _row(run, status, error, metrics, time.perf_counter() - start)


def run_folder(run: PlannedRun, out: Path) -> Path:
    """The run's folder under ``out``, with its ``run.json`` (values, seed, base scenario)."""
    run_dir = out / RUNS_DIR / run.run_id
    run_dir.mkdir(parents=True, exist_ok=True)
    (run_dir / "run.json").write_text(json.dumps(
        {"run": run.run_id, "parameters": run.parameters, "seed": run.seed,
         "scenario": run.scenario_path, "raycast_sensors": run.raycast_sensors},
        indent=2, default=str) + "\n")
    return run_dir


def one_line(error: BaseException) -> str:
    """The one-line message of a run's error (uhrisim's own errors are one line already)."""
    if isinstance(error, UhrisimError):
        return str(error)
    return f"{type(error).__name__}: {first_line(error)}"


def _row(run: PlannedRun, status: str, error: str | None, metrics: dict[str, Any],
         wall_s: float | None) -> dict[str, Any]:
    row: dict[str, Any] = {"run": run.run_id, "status": status, "seed": run.seed}
    row |= run.parameters
    row |= {"error": error, "run_wall_s": wall_s}
    row |= {k: v for k, v in flatten(metrics).items() if k not in _REPEATED}
    return row


def flatten(metrics: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"a": {"b": 1}}`` -> ``{"a.b": 1}``."""
    flat: dict[str, Any] = {}
    for key, value in metrics.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            flat |= flatten(value, name + ".")
        else:
            flat[name] = value
    return flat


def run_sweep(sweep_path: str | Path, out: str | Path, *, address: str | None = None,
              workers: int | None = None, limit: int | None = None,
              progress: Callable[[int, int], None] | None = None) -> SweepResult:
    """Plan the sweep, run what is not done yet on Ray, write the table and the figure.

    ``limit``: only the first ``limit`` planned runs (a small try of a big sweep; the same
    runs, seeds and folders as in the whole sweep, so a later full run skips them).
    ``progress(done, total)`` is called as runs finish (skipped ones count as done)."""
    if limit is not None and limit < 1:
        raise ConfigError(f"must be an integer >= 1, got {limit!r}", where="--limit")
    plan = load_sweep(sweep_path)
    check_address(address)  # before anything is written
    out = Path(out)
    (out / RUNS_DIR).mkdir(parents=True, exist_ok=True)
    runs = plan.runs[:limit]
    rows: list[dict[str, Any] | None] = [None] * len(runs)
    todo: list[PlannedRun] = []
    for run in runs:
        finished = completed_metrics(out / RUNS_DIR / run.run_id)
        if run.error is not None:  # refused by the schema: recorded, never run
            (run_folder(run, out) / "error.txt").write_text(run.error + "\n")
            rows[run.index] = _row(run, "failed", run.error, {}, None)
        elif finished is not None:
            rows[run.index] = _row(run, "ok", None, finished, None)
        else:
            todo.append(run)
    skipped = sum(r is not None and r["status"] == "ok" for r in rows)
    done = len(runs) - len(todo)
    if progress:
        progress(done, len(runs))

    def finished_one(index: int, row: dict[str, Any]) -> None:
        nonlocal done
        rows[todo[index].index] = row
        done += 1
        if progress:
            progress(done, len(runs))

    def lost_one(index: int, error: BaseException) -> None:
        """A run whose worker died (out of memory, a lost node): failed, the rest go on."""
        finished_one(index, _row(todo[index], "failed", one_line(error), {}, None))

    nodes: dict[str, int] = {}
    if todo:
        with ray_session(address, workers) as in_flight:
            nodes = dict(run_tasks(execute_run, [(run, str(out)) for run in todo], in_flight,
                                   finished_one, lost_one))
    result = SweepResult([r for r in rows if r is not None], skipped, nodes=nodes,
                         planned=len(plan.runs))
    result.files = write_table(result.rows, plan.parameters, out)
    # here: matplotlib and scipy.stats take seconds to import, which the Ray workers that
    # import this module for execute_run need not pay
    from uhrisim.batch.figures import plot_sweep_summary

    result.files.append(plot_sweep_summary(result.rows, plan.parameters, out / "summary.png",
                                           plan.name))
    return result


def write_table(rows: list[dict[str, Any]], parameters: list[str], out: Path) -> list[Path]:
    """``results.parquet`` (pyarrow) and ``results.csv``: one row per run, the columns in
    the order run, status, seed, parameters, error, then every metric seen."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    columns = list(dict.fromkeys(["run", "status", "seed", *parameters, "error", "run_wall_s",
                                  *(k for row in rows for k in row)]))
    arrays = {}
    for name in columns:
        values = [row.get(name) for row in rows]
        try:  # a column with no value yet (nothing acquired) is a number column
            kind = pa.float64() if all(v is None for v in values) else None
            arrays[name] = pa.array(values, type=kind)
        except (pa.ArrowInvalid, pa.ArrowTypeError):  # mixed kinds: kept as text
            arrays[name] = pa.array([None if v is None else str(v) for v in values])
    parquet = out / "results.parquet"
    pq.write_table(pa.table(arrays), parquet)
    table_csv = out / "results.csv"
    with table_csv.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle)
        writer.writerow(columns)
        for row in rows:
            writer.writerow(["" if row.get(c) is None else row.get(c) for c in columns])
    return [parquet, table_csv]
