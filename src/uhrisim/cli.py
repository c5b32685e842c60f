"""The ``uhrisim`` command line: run missions, make the paper's figures, benchmark.

Library errors (``UhrisimError``) become one-line messages and exit status 2, printed as
plain text (a message is never read as Rich markup: brackets in a path or a key stay);
every option is checked before any work starts. Nothing here computes physics.
"""

from __future__ import annotations

import contextlib
import functools
import gc
import importlib
import json
import logging
import math
import sys
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table
from rich.text import Text

from uhrisim.core.errors import (
    ConfigError,
    StopRequested,
    UhrisimError,
    UhrisimWarning,
    shortened,
)
from uhrisim.core.memory import keep_freed_memory
from uhrisim.core.opencv_threads import one_opencv_thread
from uhrisim.core.stops import (
    catch_stop_signals,
    handlers_kept,
    pending_stop,
    stop_handled,
    stop_message,
    stop_signum,
)

app = typer.Typer(
    name="uhrisim",
    help="Underwater human-robot interaction simulator: VideoRay ROV, imaging sonar, diver, "
    "MOOS-IvP-style helm (re-creating DeMarco, West & Howard, OCEANS 2013).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
console = Console()
err_console = Console(stderr=True)


#: How many times one warning (one message template) is said before its repeats are only
#: counted, and summarised in one line when the command ends.
REPEATS_SAID = 3


class _RepeatsSummarised(logging.Filter):
    """Lets each message template of uhrisim's log through :data:`REPEATS_SAID` times;
    counts the rest (20 000 objects over the recording's triangle budget are three lines
    and a summary, not 20 000 lines)."""

    def __init__(self) -> None:
        super().__init__()
        self.seen: dict[tuple[str, str], list[Any]] = {}  # template: [count, first message]

    def filter(self, record: logging.LogRecord) -> bool:
        entry = self.seen.setdefault((record.name, str(record.msg)), [0, record.getMessage()])
        entry[0] += 1
        return entry[0] <= REPEATS_SAID

    def summary(self) -> list[str]:
        """One line per template said more often than shown; the counts start again."""
        lines = [f"... and {count - REPEATS_SAID} more like: {shortened(first, 200)}"
                 for count, first in self.seen.values() if count > REPEATS_SAID]
        self.seen.clear()
        return lines


_REPEATS = _RepeatsSummarised()


class _StderrHandler(logging.StreamHandler):
    """Python's last-resort handler as a handler of its own: warnings and errors, plain,
    on whatever ``sys.stderr`` is when one is written."""

    def __init__(self) -> None:
        super().__init__()
        self.setLevel(logging.WARNING)
        self.addFilter(_REPEATS)

    @property
    def stream(self) -> Any:  # type: ignore[override]
        return sys.stderr

    @stream.setter
    def stream(self, _value: Any) -> None:
        pass


def _log_to_stderr() -> None:
    """uhrisim's warnings on stderr, as plain lines, each repeated one summarised."""
    logger = logging.getLogger("uhrisim")
    if not any(isinstance(h, _StderrHandler) for h in logger.handlers):
        logger.addHandler(_StderrHandler())
    _REPEATS.seen.clear()


def _say_repeats() -> None:
    for line in _REPEATS.summary():
        err_console.print(Text(line), highlight=False, soft_wrap=True)


@app.callback()
def _process_settings() -> None:
    """Process-wide settings of the command (side effects at the edge)."""
    keep_freed_memory()  # no page-fault churn on every sonar ping (see core/memory.py)
    one_opencv_thread()  # OpenCV's pool costs more CPU than it saves here (see its module)
    catch_stop_signals()
    _log_to_stderr()
    warnings.simplefilter("ignore", UhrisimWarning)  # each is logged, and shown once so

# Figure name -> "module:function(out_dir) -> list[Path]".
FIGURES: dict[str, tuple[str, str]] = {
    "openloop": ("uhrisim.experiments.openloop:make_openloop",
                 "paper Figs 5-8: open-loop VideoRay run, CSV + 4 PNG"),
    "sonar-pier": ("uhrisim.viz.sonar_figures:make_sonar_pier",
                   "paper Figs 12-14: pier support beams over bathymetry"),
    "sonar-torus": ("uhrisim.viz.sonar_figures:make_sonar_torus",
                    "paper Figs 15-16: a torus on the sea floor"),
    "sonar-tank": ("uhrisim.viz.sonar_figures:make_sonar_tank",
                   "test tank: 30 fan + label images and their statistics vs real frames"),
    "sonar-presets": ("uhrisim.viz.sonar_figures:make_sonar_presets",
                      "every sonar preset in the test tank, drawn as its maker's viewer does"),
    "camera": ("uhrisim.viz.camera_figures:make_camera",
               "the diver in clear, coastal and turbid water, near and far, lamps on/off"),
    "sonar-trail": ("uhrisim.experiments.sonar_trail:make_sonar_trail",
                    "issue 15: sonar-only trail, 3 seeds x 10 min, paper + cluttered (~10 min)"),
    "team-timeline": ("uhrisim.viz.team_figures:make_team_timeline",
                      "a run's diver orders as a Gantt chart (--run RUN_FOLDER)"),
    "signal-range": ("uhrisim.experiments.signal_range:make_signal_range",
                     "issue 26: markers, gestures and the sonar wave read vs range, water, "
                     "lamps (~1 h)"),
    "assisted-salvage": ("uhrisim.experiments.assisted_salvage:make_assisted_salvage",
                         "issue 26: the assisted salvage (3 seeds, clear water; 9C) against "
                         "the diver alone (~1 h)"),
}


#: The figures whose sonar ``--preset`` picks.
PRESET_FIGURES = ("sonar-tank", "sonar-pier", "sonar-torus")
#: The figures that draw a run (``--run``).
RUN_FIGURES = ("team-timeline",)


def _resolve(target: str) -> Callable[..., Any]:
    module_name, function_name = target.split(":")
    return getattr(importlib.import_module(module_name), function_name)


def report_error(message: object) -> None:
    """``error: <message>`` on stderr, the message as plain text (never Rich markup)."""
    err_console.print(Text.assemble(("error: ", "bold red"), shortened(str(message), 2000)),
                      highlight=False, soft_wrap=True)


def friendly_errors(command: Callable[..., Any]) -> Callable[..., Any]:
    """Turn uhrisim's own errors and the file system's refusals (a path too long, a
    read-only folder) into a one-line message and exit status 2, and a stop
    (Ctrl-C, SIGTERM, SIGHUP: the work has cleaned up by then) into one line and exit
    status 128 + the signal's number."""

    @functools.wraps(command)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            try:
                return command(*args, **kwargs)
            finally:
                _say_repeats()  # before the error line, which stays the last
        except UhrisimError as error:
            report_error(error)
            raise typer.Exit(code=2) from None
        except OSError as error:  # the file system said no: a name too long, a read-only
            if error.filename is None:  # folder, no permission; a path, so the user's to fix
                raise
            report_error(f"{shortened(str(error.filename), 200)}: {error.strerror or error}")
            raise typer.Exit(code=2) from None
        except (KeyboardInterrupt, StopRequested) as stop:
            stop_handled()
            signum = stop_signum(stop)
            report_error(stop_message(signum))
            raise typer.Exit(code=128 + signum) from None

    return wrapper


def check_option(name: str, value: float | None, ok: bool, rule: str) -> None:
    """A ConfigError naming the option when ``value`` breaks its ``rule``."""
    if value is not None and not ok:
        raise ConfigError(f"--{name} must be {rule}, got {value!r}")


def check_run_options(duration: float | None, seed: int | None, rtf: float | None,
                      port: int | None = None) -> None:
    """The run options, checked before anything is built."""
    finite = duration is not None and math.isfinite(duration)
    check_option("duration", duration, finite and duration > 0, "a finite number of seconds > 0")
    check_option("seed", seed, seed is not None and 0 <= seed < 2**63, "an integer >= 0")
    check_option("rtf", rtf, rtf is not None and math.isfinite(rtf) and rtf >= 0,
                 "a finite number >= 0")
    check_option("port", port, port is not None and 0 <= port <= 65535, "in 0..65535")


#: The figures that run missions: ``--seeds`` and ``--duration`` size them.
MISSION_FIGURES = ("sonar-trail",)


@app.command()
@friendly_errors
def figure(
    name: Annotated[str, typer.Argument(help=f"one of: {', '.join(FIGURES)}")],
    out: Annotated[Path, typer.Option("--out", "-o", help="output folder")] = Path("out/figures"),
    preset: Annotated[str | None, typer.Option(
        "--preset", help=f"the sonar of {', '.join(PRESET_FIGURES)} (a sonar preset name)",
    )] = None,
    seeds: Annotated[str | None, typer.Option(
        "--seeds", help=f"{', '.join(MISSION_FIGURES)}: the seeds, comma-separated (fewer "
                        "seeds, a quicker figure)")] = None,
    duration: Annotated[float | None, typer.Option(
        help=f"{', '.join(MISSION_FIGURES)}: simulated seconds per mission")] = None,
    run: Annotated[Path | None, typer.Option(
        "--run", help="the run folder a run figure draws (team-timeline)")] = None,
) -> None:
    """Reproduce a figure of the paper into OUT (or draw one of a run: --run)."""
    if name not in FIGURES:
        raise ConfigError(f"unknown figure {name!r}; choose from {', '.join(FIGURES)}")
    if preset is not None and name not in PRESET_FIGURES:
        raise ConfigError(f"--preset applies to {', '.join(PRESET_FIGURES)}, not {name!r}")
    from uhrisim.app.runner import prepare_out_dir

    prepare_out_dir(out)  # a file, a device or a folder that cannot be written: one line
    if (seeds is not None or duration is not None) and name not in MISSION_FIGURES:
        raise ConfigError(f"--seeds and --duration apply to {', '.join(MISSION_FIGURES)}, "
                          f"not {name!r}")
    if run is not None and name not in RUN_FIGURES:
        raise ConfigError(f"--run applies to {', '.join(RUN_FIGURES)}, not {name!r}")
    kwargs: dict[str, Any] = {} if preset is None else {"preset": preset}
    if duration is not None:
        check_option("duration", duration, math.isfinite(duration) and duration > 0,
                     "a number of seconds > 0")
        kwargs["duration"] = duration
    if seeds is not None:
        kwargs["seeds"] = _seed_list(seeds)
    if name in RUN_FIGURES:
        kwargs["run"] = run
    if name in MISSION_FIGURES:
        with _progress(f"figure {name}", None, "s simulated", _simulated_columns(),
                       simulated=True) as update:
            paths = _resolve(FIGURES[name][0])(out, progress=update, **kwargs)
    else:
        paths = _resolve(FIGURES[name][0])(out, **kwargs)
    for path in paths:
        console.print(Text(f"wrote {path}"))


def _seed_list(text: str) -> tuple[int, ...]:
    """``"11,12"`` -> (11, 12); a one-line error for anything but integers >= 0."""
    try:
        seeds = tuple(int(part) for part in text.split(","))
    except ValueError:
        seeds = ()
    if not seeds or any(seed < 0 for seed in seeds):
        raise ConfigError(f"--seeds: expected integers >= 0 separated by commas, got {text!r}")
    return seeds


def _print_tree(result: dict[str, Any], title: str) -> None:
    table = Table(title=title, show_header=True, header_style="bold")
    table.add_column("measure")
    table.add_column("value", justify="right")

    def walk(prefix: str, node: Any) -> None:
        if isinstance(node, dict):
            for key, value in node.items():
                walk(f"{prefix}.{key}" if prefix else str(key), value)
        elif isinstance(node, float):
            table.add_row(prefix, f"{node:,.4g}")
        else:
            table.add_row(prefix, str(node))

    walk("", result)
    console.print(table)


@app.command()
@friendly_errors
def bench(
    name: Annotated[str, typer.Argument(help="benchmark name, or 'all'")] = "all",
    as_json: Annotated[bool, typer.Option("--json", help="print one JSON object")] = False,
    quick: Annotated[bool, typer.Option("--quick", help="a few seconds per benchmark")] = False,
) -> None:
    """Measure rates and ratios (steps/s, pings/s, real-time factors)."""
    from uhrisim.bench import available, run_benchmark

    names = available() if name == "all" else [name]
    unknown = [n for n in names if n not in available()]
    if unknown:
        raise ConfigError(f"unknown benchmark {unknown[0]!r}; "
                          f"available: {', '.join(available())}")
    results = {n: run_benchmark(n, quick=quick) for n in names}
    if as_json:
        sys.stdout.write(json.dumps(results if name == "all" else results[name], indent=2) + "\n")
        return
    for bench_name, result in results.items():
        _print_tree(result, f"uhrisim bench {bench_name}")


def _run_with_progress(scenario: Path, out: Path, duration: float | None, seed: int | None,
                       raycast_sensors: bool, quiet: bool = False, ros2: bool = False,
                       moos: bool = False, rtf: float | None = None,
                       view_port: int | None = None, lockstep: bool = False,
                       ros_args: tuple[str, ...] = (), require_helm: bool = False,
                       used: str = "keep", foxglove_port: int | None = None,
                       figures: bool = True) -> Any:
    from uhrisim.app.runner import prepare_out_dir, run_scenario
    from uhrisim.bridges.live import live_hooks
    from uhrisim.scenario.load import load_scenario

    source = load_scenario(scenario)
    prepare_out_dir(out, used)  # before the progress bar: a refusal is one line
    hooks = live_hooks(source.scenario, ros2=ros2, moos=moos, real_time_factor=rtf,
                       paced_elsewhere=view_port is not None, lockstep=lockstep,
                       ros_args=ros_args, require_helm=require_helm,
                       foxglove_port=foxglove_port)
    servers: list[Any] = []

    def attach(sim: Any) -> None:
        from uhrisim.viz.viewer import attach_viewer

        server, _ = attach_viewer(sim, port=view_port, speed=rtf or 1.0)
        servers.append(server)
        err_console.print(Text.assemble(("viewer: ", "bold"),
                                        f"{server.url}  (serving on 127.0.0.1 only)"))

    total = source.scenario.duration if duration is None else duration
    with _progress(source.scenario.name, total, "s simulated", _simulated_columns(),
                   quiet=quiet, simulated=True) as update:
        try:
            return run_scenario(source, out, duration=duration, seed=seed,
                                raycast_sensors=raycast_sensors, figures=figures,
                                extra_hooks=hooks, configure=None if view_port is None else attach,
                                progress=update)
        finally:
            for server in servers:
                server.close()


#: Wall seconds between progress lines off a terminal (logs, pipes, CI).
PROGRESS_EVERY_S = 10.0


@contextlib.contextmanager
def _progress(what: str, total: float | None, unit: str, columns: tuple[Any, ...],
              quiet: bool = False, simulated: bool = False
              ) -> Iterator[Callable[..., None]]:
    """``update(done, total=None)`` for a long step: a Rich progress bar on a terminal
    (cleared at the end), one line every PROGRESS_EVERY_S s off one (``app.progress``),
    nothing when ``quiet``; all on stderr."""
    from rich.progress import Progress

    from uhrisim.app.progress import ProgressLines

    if quiet or not err_console.is_terminal:
        lines = ProgressLines(what, total, unit, every_s=PROGRESS_EVERY_S, simulated=simulated,
                              write=lambda line: err_console.print(Text(line), soft_wrap=True))

        def update_lines(done: float, new_total: float | None = None) -> None:
            if not quiet:
                lines.update(done, new_total)

        yield update_lines
        if not quiet:
            lines.finish()
        return
    with Progress(*columns, console=err_console, transient=True) as bar:
        task = bar.add_task(escape(what), total=total)
        yield lambda done, new_total=None: bar.update(
            task, completed=done, **({} if new_total is None else {"total": new_total}))


def _print_metrics(result: Any) -> None:
    m = result.metrics or {}
    table = Table(title="mission metrics", show_header=False)
    table.add_column("metric")
    table.add_column("value", justify="right")
    rows = [("simulated", f"{m.get('simulated_s', 0):.0f} s"),
            ("real-time factor", f"{m.get('real_time_factor') or 0:.1f}x")]
    if "acquired" in m:
        acquire = m["time_to_acquire_s"]
        rows += [
            ("trail acquired after", "never" if acquire is None else f"{acquire:.1f} s"),
            ("range error RMS", _fmt(m["range_error_m"]["rms"], "m")),
            ("bearing error RMS", _fmt(m["bearing_error_deg"]["rms"], "deg")),
            ("depth error RMS", _fmt(m["depth_error_m"]["rms"], "m")),
            ("minimum separation", _fmt(m["min_separation_m"], "m")),
        ]
    rows.append(("collisions", str(m.get("collisions", 0))))
    for bridge in ("moos", "ros2"):  # agents driven from outside (bridges.helm_watch)
        section = m.get(bridge) or {}
        watches = {name: link["helm"] for name, link in section.items()
                   if isinstance(link, dict) and "helm" in link} if bridge == "moos" \
            else section.get("helm", {})
        for name, watch in watches.items():
            rows.append((f"outside helm of {name} ({bridge.upper()})", _helm_row(watch)))
    seen = m.get("perception")
    if seen:  # contacts from the sonar (docs/perception.md)
        held = seen["held_pct"]
        rows += [("diver held by a sonar track", "never" if held is None else f"{held:.1f} %"),
                 ("sonar track error RMS", _fmt(seen["track_error_m"]["rms"], "m")),
                 ("track identity switches", str(seen["identity_switches"]))]
    for name, value in rows:
        table.add_row(name, value)
    console.print(table)
    for path in result.files:
        console.print(Text(f"  wrote {path}"))


def _helm_row(watch: dict[str, Any]) -> str:
    """How an outside helm drove, in a few words (its watch's summary in metrics.json)."""
    first = watch["first_command_s"]
    state = f", IVPHELM_STATE={watch['helm_state']}" if watch.get("helm_state") else ""
    if first is None:
        return f"never drove{state}"
    return (f"first command at {first:.1f} s, {watch['seconds_without_commands']:.0f} s "
            f"without{state}")


def _fmt(value: float | None, unit: str) -> str:
    return "n/a" if value is None else f"{value:.2f} {unit}"


@app.command()
@friendly_errors
def run(
    scenario: Annotated[Path, typer.Argument(help="scenario YAML file")],
    out: Annotated[Path | None, typer.Option("--out", "-o",
                                             help="output folder (default out/<name>)")] = None,
    duration: Annotated[float | None, typer.Option(help="simulated seconds")] = None,
    seed: Annotated[int | None, typer.Option(help="root random seed")] = None,
    no_raycast_sensors: Annotated[bool, typer.Option(
        "--no-raycast-sensors",
        help="no sonars and no cameras (the sensors that cast rays into the scene)")] = False,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="no progress bar")] = False,
    no_figures: Annotated[bool, typer.Option(
        "--no-figures", help="no figures (trajectory.png, ...): the recording and "
                             "metrics.json only, a second or two of matplotlib sooner")] = False,
    ros2: Annotated[bool, typer.Option("--ros2", help="bridge to ROS 2 (loopback only)")] = False,
    moos: Annotated[bool, typer.Option("--moos", help="bridge to MOOSDB(s) on 127.0.0.1")] = False,
    lockstep: Annotated[bool, typer.Option(
        "--lockstep", help="ROS 2 in lockstep: each odometry period waits for the "
                           "controllers' commands (repeatable runs; implies --ros2)")] = False,
    rtf: Annotated[float | None, typer.Option(
        "--rtf", help="with a bridge or the viewer: pace to wall clock x RTF (0 = run free)"
    )] = None,
    view: Annotated[bool, typer.Option("--view", help="watch live in the browser")] = False,
    port: Annotated[int, typer.Option(help="viewer port on 127.0.0.1 (0 = any)")] = 8765,
    ros_args: Annotated[str, typer.Option(
        "--ros-args", help="ROS 2 node arguments, as ros2 run takes them: everything "
                           "after --ros-args (up to --) goes to ROS, e.g. --ros-args -r "
                           "__ns:=/sim_a -p sensor_qos:=reliable (implies --ros2)")] = "",
    require_helm: Annotated[bool, typer.Option(
        "--require-helm", help="end the run as failed (exit status 2) when an agent's "
                               "outside helm (MOOS or ROS 2) does not drive it: MALCONFIG, "
                               "parked, an all-stop or no commands (bridges.helm_watch)")
    ] = False,
    overwrite: Annotated[bool, typer.Option(
        "--overwrite", help="replace the outputs of an earlier run in OUT (its files are "
                            "deleted first); without it a non-empty OUT is refused")] = False,
    foxglove: Annotated[bool, typer.Option(
        "--foxglove", help="serve the run live to Foxglove (ws://127.0.0.1:PORT; the "
                           "recording's channels; needs uhrisim[foxglove])")] = False,
    foxglove_port: Annotated[int, typer.Option(
        "--foxglove-port", help="Foxglove server port on 127.0.0.1 (0 = any)")] = 8765,
) -> None:
    """Run a scenario: the recording (a rosbag2 folder), metrics.json and figures go to OUT."""
    import shlex

    check_run_options(duration, seed, rtf, port)
    check_option("foxglove-port", foxglove_port, 0 <= foxglove_port <= 65535, "in 0..65535")
    out = out or Path("out") / scenario.stem
    try:
        extra_ros_args = tuple(shlex.split(ros_args))
    except ValueError as error:  # "No closing quotation", "No escaped character"
        raise ConfigError(f"--ros-args: {error} in {shortened(ros_args, 200)!r}") from None
    result = _run_with_progress(scenario, out, duration, seed, not no_raycast_sensors, quiet,
                                ros2=ros2 or bool(extra_ros_args), moos=moos, rtf=rtf,
                                view_port=port if view else None, lockstep=lockstep,
                                ros_args=extra_ros_args, require_helm=require_helm,
                                used="clear" if overwrite else "refuse",
                                foxglove_port=foxglove_port if foxglove else None,
                                figures=not no_figures)
    _print_metrics(result)


@app.command()
@friendly_errors
def validate(scenario: Annotated[Path, typer.Argument(help="scenario YAML file")]) -> None:
    """Check a scenario file (and the behavior files it names) without running it."""
    from uhrisim.app.runner import build_run
    from uhrisim.scenario.load import load_scenario

    source = load_scenario(scenario)
    build_run(source)  # what run builds (helms, sensors, scene, metrics): every check
    s = source.scenario
    console.print(Text(f"{scenario}: OK — {len(s.agents)} agents "
                       f"({', '.join(a.name for a in s.agents)}), {s.duration:g} s at "
                       f"{s.physics_rate_hz:g} Hz physics"))


@app.command()
@friendly_errors
def view(
    recording: Annotated[Path, typer.Argument(help="a recording.mcap written by uhrisim run")],
    port: Annotated[int, typer.Option(help="port on 127.0.0.1 (0 = any)")] = 8765,
) -> None:
    """Replay a recorded run in the browser, with a time slider (Ctrl-C to stop)."""
    import time

    from uhrisim.record.recover import recover_in_place
    from uhrisim.viz.viewer import serve_replay

    check_option("port", port, 0 <= port <= 65535, "in 0..65535")
    _recover_if_cut(recording, recover_in_place)
    size_mb = recording.stat().st_size / 1e6 if recording.is_file() else 0.0
    err_console.print(Text(f"indexing {recording} ({size_mb:.0f} MB): reading tracks, sonar "
                           "and camera frames…"), highlight=False, soft_wrap=True)
    started = time.monotonic()
    server = serve_replay(recording, port=port)
    err_console.print(Text(f"indexed in {time.monotonic() - started:.1f} s"), highlight=False,
                      soft_wrap=True)
    console.print(Text.assemble((f"replay of {recording}: ", "bold"),
                                f"{server.url}  (Ctrl-C to stop)"))
    try:
        while True:
            time.sleep(0.5)
    except KeyboardInterrupt:
        pass
    finally:
        server.close()


@app.command()
@friendly_errors
def demo(
    out: Annotated[Path, typer.Option("--out", "-o", help="output folder")] = Path("out/demo"),
    duration: Annotated[float, typer.Option(help="simulated seconds")] = 600.0,
) -> None:
    """The paper's track-and-trail mission (Fig. 19), headless, plus Figs 5-8."""
    check_run_options(duration, None, None)
    console.print("[bold]uhrisim demo:[/] the VideoRay tracks and trails a loitering diver "
                  f"for {duration:g} simulated seconds (DeMarco et al. 2013, Fig. 19)")
    from uhrisim.scenario.shipped import shipped_scenario

    result = _run_with_progress(shipped_scenario(), out, duration, None, True)
    _print_metrics(result)
    for path in _resolve(FIGURES["openloop"][0])(out / "openloop"):
        console.print(Text(f"  wrote {path}"))



scenarios_app = typer.Typer(
    help="The example scenarios shipped inside the package: list them, or copy one to edit.",
    no_args_is_help=False)
app.add_typer(scenarios_app, name="scenarios")


@scenarios_app.callback(invoke_without_command=True)
@friendly_errors
def scenarios(ctx: typer.Context) -> None:
    """List the shipped scenarios (run one with uhrisim run $(uhrisim scenarios path NAME))."""
    if ctx.invoked_subcommand is not None:
        return
    from uhrisim.scenario.shipped import scenario_summary, shipped_scenario, shipped_scenarios

    table = Table(title="shipped scenarios (uhrisim scenarios copy NAME DIR to edit one)")
    table.add_column("name")
    table.add_column("what it is")
    for name in shipped_scenarios():
        table.add_row(name.removesuffix(".yaml"), scenario_summary(shipped_scenario(name)))
    console.print(table)


@scenarios_app.command("copy")
@friendly_errors
def scenarios_copy(
    name: Annotated[str, typer.Argument(help="shipped scenario name (uhrisim scenarios)")],
    destination: Annotated[Path, typer.Argument(help="folder to copy into (created)")],
) -> None:
    """Copy a shipped scenario and the behavior/MOOS files it names into DESTINATION."""
    from uhrisim.scenario.shipped import copy_scenario

    for path in copy_scenario(name, destination):
        console.print(Text(f"  wrote {path}"))


@scenarios_app.command("path")
@friendly_errors
def scenarios_path(
    name: Annotated[str, typer.Argument(help="shipped scenario name (uhrisim scenarios)")],
) -> None:
    """Print the installed path of a shipped scenario (to run it as it is)."""
    from uhrisim.scenario.shipped import shipped_scenario

    sys.stdout.write(f"{shipped_scenario(name)}\n")


RayAddress = Annotated[str | None, typer.Option(
    help="Ray cluster: 'auto' or ray://host:port (default: a local Ray, loopback only)")]
RayWorkers = Annotated[int | None, typer.Option(help="Ray tasks at a time (default: all CPUs)")]


def _on_ray(what: str, unit: str, workers: int | None, work: Callable[..., Any]) -> Any:
    """``work(progress=...)`` with the progress of ``what`` (a count of ``unit``) on
    stderr (``_progress``), ``--workers`` checked first."""
    check_option("workers", workers, workers is not None and workers >= 1, "an integer >= 1")
    with _progress(what, None, unit, _count_columns(unit)) as update:
        return work(progress=update)


def _simulated_columns() -> tuple[Any, ...]:
    """The progress bar's columns for simulated seconds."""
    from rich.progress import BarColumn, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    return (TextColumn("[bold]{task.description}"), BarColumn(),
            TextColumn("{task.completed:>6.0f}/{task.total:.0f} s simulated"),
            TimeElapsedColumn(), TimeRemainingColumn())


def _count_columns(what: str) -> tuple[Any, ...]:
    """The progress bar's columns for a count of ``what`` (runs, frames, missions)."""
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    return (TextColumn(f"[bold]{what}"), BarColumn(), MofNCompleteColumn(),
            TimeElapsedColumn(), TimeRemainingColumn())


def _print_lines(lines: list[str]) -> None:
    for line in lines:
        console.print(Text(line), soft_wrap=True)


@app.command()
@friendly_errors
def sweep(
    sweep_file: Annotated[Path, typer.Argument(help="sweep YAML file")],
    out: Annotated[Path, typer.Option("--out", "-o", help="output folder")],
    address: RayAddress = None,
    workers: RayWorkers = None,
    limit: Annotated[int | None, typer.Option(
        help="only the first N planned runs (a small try; a later full sweep skips them)")
    ] = None,
) -> None:
    """Run a parameter sweep on Ray: a run folder per run, results.parquet/.csv, summary.png."""
    from uhrisim.batch.sweep import run_sweep

    check_option("limit", limit, limit is None or limit >= 1, "an integer >= 1")
    result = _on_ray("sweep", "runs", workers, functools.partial(
        run_sweep, sweep_file, out, address=address, workers=workers, limit=limit))
    of_planned = (f" (the first {len(result.rows)} of {result.planned} planned)"
                  if result.planned > len(result.rows) else "")
    lines = [f"{len(result.rows)} runs{of_planned}: {len(result.rows) - result.failed} ok "
             f"({result.skipped} already done), {result.failed} failed"
             + _on_nodes(result.nodes)]
    lines += [f"  failed {row['run']}: {row['error']}" for row in result.rows
              if row["status"] == "failed"]
    _print_lines(lines + [f"  wrote {path}" for path in result.files])


def _on_nodes(nodes: dict[str, int]) -> str:
    """``"; on 2 Ray nodes"`` (nothing for work that ran nowhere)."""
    return f"; on {len(nodes)} Ray node{'s' if len(nodes) != 1 else ''}" if nodes else ""


@app.command()
@friendly_errors
def dataset(
    dataset_file: Annotated[Path, typer.Argument(help="dataset YAML file")],
    out: Annotated[Path, typer.Option("--out", "-o", help="output folder")],
    address: RayAddress = None,
    workers: RayWorkers = None,
    shard_frames: Annotated[int, typer.Option(help="frames per Ray task")] = 25,
    frames: Annotated[int | None, typer.Option(
        help="render N frames instead of the file's count (frame i is the same either way)")
    ] = None,
) -> None:
    """Render a labelled sonar dataset on Ray: images, label images, COCO, card, preview."""
    from uhrisim.batch.dataset import run_dataset

    check_option("shard-frames", shard_frames, shard_frames >= 1, "an integer >= 1")
    check_option("frames", frames, frames is None or frames >= 1, "an integer >= 1")
    result = _on_ray("dataset", "frames", workers, functools.partial(
        run_dataset, dataset_file, out, address=address, workers=workers,
        shard_frames=shard_frames, frames=frames))
    _print_lines([f"{result.frames} frames, {result.annotations} annotated instances"
                  + _on_nodes(result.nodes)]
                 + [f"  wrote {path}" for path in result.files])


def _recover_if_cut(recording: Path, recover_in_place: Callable[[Path], int | None]) -> None:
    """Make a recording a killed run cut short complete (kept as ``.partial``), saying so."""
    count = recover_in_place(recording)
    if count is not None:
        err_console.print(Text(f"{recording}: the run was cut short; recovered {count} "
                               f"messages (the cut file is kept as {recording}.partial)"))


@app.command()
@friendly_errors
def recover(
    run: Annotated[Path, typer.Argument(help="a run's output folder, or its recording.mcap")],
) -> None:
    """Make the recording of a killed run complete, so that every MCAP reader opens it."""
    from uhrisim.record.recover import recover_in_place

    recording = run / "recording.mcap" if run.is_dir() else run
    count = recover_in_place(recording)
    if count is None:
        console.print(Text(f"{recording}: complete, nothing to recover"))
    else:
        console.print(Text(f"{recording}: recovered {count} messages "
                           f"(the cut file is kept as {recording}.partial)"))


@app.command("ros2-interfaces")
def ros2_interfaces(
    into: Annotated[Path | None, typer.Option(
        "--into", metavar="VENV", help="another virtual environment: the ros2 extra's "
        "wheels are installed there, then the packages built into it")] = None,
    force: Annotated[bool, typer.Option("--force", help="rebuild every package")] = False,
    no_deps: Annotated[bool, typer.Option(
        "--no-deps", help="with --into: do not install the ros2 extra's wheels")] = False,
) -> None:
    """Build tf2_msgs, marine_acoustic_msgs and uhrisim_msgs (no wheels) into a Python
    environment, for the ROS 2 bridge and for nodes that subscribe to its topics."""
    from uhrisim.bridges.ros2.interfaces.__main__ import main as build_interfaces

    argv = (["--into", str(into)] if into is not None else []) + (
        ["--force"] if force else []) + (["--no-deps"] if no_deps else [])
    raise typer.Exit(build_interfaces(argv))


@app.command("sonar-stats")
@friendly_errors
def sonar_stats(
    folder: Annotated[Path, typer.Argument(help="folder of *_fan.png + *_labels.png images")],
    as_json: Annotated[bool, typer.Option("--json", help="print one JSON object")] = False,
) -> None:
    """Speckle contrast, object/background ratio, zero pixels and brightness profiles of
    sonar fan images with label images (see docs/sonar.md)."""
    from uhrisim.sensors.sonar.stats import (
        GEOMETRY_FILE,
        image_stats,
        load_frames,
        load_px_per_m,
    )

    px_per_m = load_px_per_m(folder)
    stats = image_stats(*load_frames(folder), px_per_m=px_per_m)
    if as_json:
        sys.stdout.write(json.dumps(stats, indent=2) + "\n")
        return
    summary = {k: v for k, v in stats.items() if k != "per_frame"}
    axes = {"range_profile": ("range_m" if px_per_m else "range_px"),
            "bearing_profile": "bearing_deg"}
    for key, axis_name in axes.items():
        profile = summary.pop(key)
        pairs = zip(profile[axis_name], profile["relative_brightness"], strict=True)
        label = {"range_m": "range m", "range_px": f"range px (no {GEOMETRY_FILE})",
                 "bearing_deg": "bearing deg"}[axis_name]
        summary[f"{key} ({label}: brightness/mean)"] = "  ".join(
            f"{a:.3g}:{v:.2f}" for a, v in pairs if a is not None and v is not None)
    _print_tree(summary, f"uhrisim sonar-stats {folder}")


def _range_window(text: str | None, option: str) -> tuple[float, float] | None:
    """``MIN:MAX`` metres (0 ≤ MIN < MAX) as a tuple; ConfigError naming the option."""
    if text is None:
        return None
    try:
        near, far = (float(x) for x in text.split(":"))
    except ValueError:
        raise ConfigError(f"--{option} must be MIN:MAX in metres, got {text!r}") from None
    if not (math.isfinite(near) and math.isfinite(far) and 0.0 <= near < far):
        raise ConfigError(f"--{option} must have 0 <= MIN < MAX, got {text!r}")
    return near, far


@app.command("sonar-compare")
@friendly_errors
def sonar_compare(
    real: Annotated[Path, typer.Argument(help="folder of real 8-bit fan frames (*.png)")],
    sim: Annotated[Path, typer.Argument(help="folder of simulated 8-bit fan frames")],
    preset: Annotated[str | None, typer.Option(
        "--preset", help="the sonar of both folders: field of view, beam width, range "
        "resolution (the grain in resolution cells)")] = None,
    fov: Annotated[float | None, typer.Option(
        "--fov", help="field of view, degrees (without --preset)")] = None,
    range_window: Annotated[str | None, typer.Option(
        "--range", help="the frames' range window MIN:MAX, metres")] = None,
    sim_preset: Annotated[str | None, typer.Option(
        "--sim-preset", help="SIM's sonar, when it is not REAL's")] = None,
    out: Annotated[Path, typer.Option("--out", "-o", help="folder for report.txt, "
                                      "report.json, compare.png")] = Path("out/sonar-compare"),
    as_json: Annotated[bool, typer.Option("--json", help="print the JSON report")] = False,
) -> None:
    """How far SIM's frames are from REAL's, measure by measure, with a verdict each:
    intensity histograms (KL, Jensen–Shannon, earth mover's), LBP texture, speckle
    (Rayleigh/K fits, KS), grain in resolution cells, brightness across the fan and along
    range, object contrast, zero and saturated pixels (see docs/sonar.md)."""
    from uhrisim.sensors.sonar.compare import FanGeometry, compare_folders, report_lines
    from uhrisim.viz.sonar_figures import make_compare_figure

    window = _range_window(range_window, "range")
    check_option("fov", fov, fov is not None and math.isfinite(fov) and 0.0 < fov < 180.0,
                 "in (0, 180) degrees")  # fmt: skip
    if preset is not None and fov is not None:
        raise ConfigError("give --preset or --fov, not both")
    geometry = None
    if preset is not None:
        geometry = FanGeometry.from_preset(preset, window)
    elif fov is not None or window is not None:
        geometry = FanGeometry(fov, window)
    sim_geometry = None if sim_preset is None else FanGeometry.from_preset(sim_preset, window)
    report, curves = compare_folders(real, sim, geometry, sim_geometry)
    out.mkdir(parents=True, exist_ok=True)
    lines = report_lines(report)
    (out / "report.json").write_text(json.dumps(report, indent=1) + "\n")
    (out / "report.txt").write_text("\n".join(lines) + "\n")
    make_compare_figure(report, curves, out / "compare.png")
    if as_json:
        sys.stdout.write(json.dumps(report, indent=2) + "\n")
        return
    sys.stdout.write("\n".join(lines) + "\n")  # (plain text: the table keeps its width)
    sys.stdout.write(f"wrote {out / 'report.txt'}, {out / 'report.json'}, "
                     f"{out / 'compare.png'}\n")  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    """The ``uhrisim`` command: the app, with command-line usage errors (an option that is
    not a number, an unknown option) also reported in one line. Returns the exit status."""
    try:
        with handlers_kept():
            status = app(args=_gather_ros_args(sys.argv[1:] if argv is None else argv),
                         prog_name="uhrisim", standalone_mode=False)
    except _USAGE_ERROR as error:
        message = error.format_message()
        if message:  # empty: no arguments at all, and the help was printed
            ctx = getattr(error, "ctx", None)
            report_error(f"{message} (see {ctx.command_path if ctx else 'uhrisim'} --help)")
        return 2
    except typer.Abort:  # click's word for a Ctrl-C outside the commands
        stop_handled()
        report_error("interrupted")
        return 130
    finally:  # the work is done and written: the interpreter's exit need not walk every
        gc.freeze()  # object of a run's heap again (seconds after a ROS run, under load)
    signum = pending_stop()
    if signum is not None:  # a stop that a library swallowed: the work went on to its end
        stop_handled()
        report_error(stop_message(signum))
        return 128 + signum
    return status if isinstance(status, int) else 0


def _gather_ros_args(argv: list[str]) -> list[str]:
    """ROS's own syntax, as ``ros2 run`` takes it: every argument after a bare
    ``--ros-args`` up to ``--`` (or the end) belongs to ROS; they become one
    ``--ros-args=...`` option (its value quoted as a shell would split it back)."""
    import shlex

    rest: list[str] = []
    ros: list[str] = []
    i = 0
    while i < len(argv):
        if argv[i] != "--ros-args":
            rest.append(argv[i])
            i += 1
            continue
        end = argv.index("--", i) if "--" in argv[i:] else len(argv)
        ros += argv[i + 1:end]
        i = end + 1
    return [*rest, f"--ros-args={shlex.join(ros)}"] if ros else rest


#: Click's UsageError (bad or unknown option, missing argument), whichever click typer
#: ships: BadParameter is its direct subclass.
_USAGE_ERROR: type[Exception] = typer.BadParameter.__mro__[1]
