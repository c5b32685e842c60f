"""The ``uhrisim`` command line: run missions, make the paper's figures, benchmark.

Library errors (``UhrisimError``) become one-line messages and exit status 2; nothing
here computes physics.
"""

from __future__ import annotations

import functools
import importlib
import json
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.table import Table

from uhrisim.core.errors import UhrisimError

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

# Figure name -> "module:function(out_dir) -> list[Path]".
FIGURES: dict[str, tuple[str, str]] = {
    "openloop": ("uhrisim.experiments.openloop:make_openloop",
                 "paper Figs 5-8: open-loop VideoRay run, CSV + 4 PNG"),
    "sonar-pier": ("uhrisim.viz.sonar_figures:make_sonar_pier",
                   "paper Figs 12-14: pier support beams over bathymetry"),
    "sonar-torus": ("uhrisim.viz.sonar_figures:make_sonar_torus",
                    "paper Figs 15-16: a torus on the sea floor"),
}


def _resolve(target: str) -> Callable[..., Any]:
    module_name, function_name = target.split(":")
    return getattr(importlib.import_module(module_name), function_name)


def friendly_errors(command: Callable[..., Any]) -> Callable[..., Any]:
    """Turn uhrisim's own errors into a one-line message and exit status 2."""

    @functools.wraps(command)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return command(*args, **kwargs)
        except UhrisimError as error:
            err_console.print(f"[bold red]error:[/] {error}", highlight=False, soft_wrap=True)
            raise typer.Exit(code=2) from None

    return wrapper


@app.command()
@friendly_errors
def figure(
    name: Annotated[str, typer.Argument(help=f"one of: {', '.join(FIGURES)}")],
    out: Annotated[Path, typer.Option("--out", "-o", help="output folder")] = Path("out/figures"),
) -> None:
    """Reproduce a figure of the paper into OUT."""
    if name not in FIGURES:
        err_console.print(f"[bold red]error:[/] unknown figure {name!r}; "
                          f"choose from {', '.join(FIGURES)}")
        raise typer.Exit(code=2)
    paths = _resolve(FIGURES[name][0])(out)
    for path in paths:
        console.print(f"wrote {path}")


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
        err_console.print(f"[bold red]error:[/] unknown benchmark {unknown[0]!r}; "
                          f"available: {', '.join(available())}")
        raise typer.Exit(code=2)
    results = {n: run_benchmark(n, quick=quick) for n in names}
    if as_json:
        sys.stdout.write(json.dumps(results if name == "all" else results[name], indent=2) + "\n")
        return
    for bench_name, result in results.items():
        _print_tree(result, f"uhrisim bench {bench_name}")


@app.command()
@friendly_errors
def demo(
    out: Annotated[Path, typer.Option("--out", "-o", help="output folder")] = Path("out/demo"),
) -> None:
    """Run the paper's experiment headless and say where the outputs went."""
    paths = _resolve(FIGURES["openloop"][0])(out)
    console.print("[bold]Open-loop VideoRay experiment (paper Figs 5-8)[/]")
    for path in paths:
        console.print(f"  wrote {path}")


def main() -> None:  # pragma: no cover - console entry point
    app()
