"""A stop signal that a library swallows (an exception raised inside its callback, printed
as "Exception ignored" and dropped) still stops the run at its next tick, and a command
that went on to its end still ends as a stop: one line, 128 + the signal's number."""

import os
import signal
import sys
from pathlib import Path

import pytest

from tests.support.small_scene import SMALL_SCENE
from uhrisim.cli import main
from uhrisim.core import stops
from uhrisim.core.errors import StopRequested
from uhrisim.scenario.load import load_scenario
from uhrisim.sim.simulation import Simulation


@pytest.fixture
def scene(tmp_path) -> Path:
    path = tmp_path / "small.yaml"
    path.write_text(SMALL_SCENE)
    return path


@pytest.fixture
def caught_stops():
    """The command line's handlers for the test, pytest's own back afterwards."""
    with stops.handlers_kept():
        stops.catch_stop_signals()
        yield
        stops.stop_handled()


def swallowed(signum: int) -> None:
    """The signal lands inside a library's callback, which drops what it raises."""
    try:
        os.kill(os.getpid(), signum)
        signal.sigtimedwait([], 0)  # let the handler run here, inside the try
    except BaseException:  # the library's swallowing, which is what is tested
        pass


def test_a_swallowed_stop_is_raised_at_the_next_tick(caught_stops, scene):
    sim = Simulation(load_scenario(scene))
    sim.step()
    swallowed(signal.SIGTERM)
    assert stops.pending_stop() == signal.SIGTERM
    with pytest.raises(StopRequested, match="stopped by SIGTERM"):
        sim.step()
    stops.stop_handled()  # (the command line does this when the stop reaches it)
    swallowed(signal.SIGINT)
    with pytest.raises(KeyboardInterrupt):
        sim.step()


def test_without_the_command_lines_handlers_nothing_is_remembered(scene):
    with stops.handlers_kept():
        signal.signal(signal.SIGINT, signal.default_int_handler)  # Python's own
        no_handlers_of_ours(scene)


def test_a_command_run_in_process_leaves_the_signal_handling_as_it_found_it(scene):
    before = {signum: signal.getsignal(signum) for signum in stops.STOP_SIGNALS}
    assert main(["validate", str(scene)]) == 0
    assert {signum: signal.getsignal(signum) for signum in stops.STOP_SIGNALS} == before


def no_handlers_of_ours(scene: Path) -> None:
    sim = Simulation(load_scenario(scene))
    with pytest.raises(KeyboardInterrupt):  # Python's own handler: raised, not remembered
        os.kill(os.getpid(), signal.SIGINT)
        signal.sigtimedwait([], 0)
    assert stops.pending_stop() is None
    sim.step()


def test_a_command_that_went_on_past_a_swallowed_stop_ends_as_a_stop(caught_stops, capsys,
                                                                     scene):
    swallowed(signal.SIGHUP)
    status = main(["validate", str(scene)])
    assert status == 128 + signal.SIGHUP
    assert capsys.readouterr().err.strip().splitlines()[-1] == "error: stopped by SIGHUP"
    assert stops.pending_stop() is None


def test_a_stop_inside_the_jit_compilers_callback_is_remembered_not_raised(caught_stops,
                                                                         monkeypatch):
    """A SIGTERM that lands in llvmlite's object-cache callback (as one did while a run
    compiled a kernel) is raised at the next tick, not inside the callback: raised there,
    llvmlite leaves its buffer unset and the process dies of a segmentation fault."""
    import llvmlite.binding as llvm

    llvm.initialize_native_target()
    llvm.initialize_native_asmprinter()
    module = llvm.parse_assembly("define i32 @seven() {\n  ret i32 7\n}\n")
    machine = llvm.Target.from_default_triple().create_target_machine()
    engine = llvm.create_mcjit_compiler(module, machine)
    asked = []

    def cached_object(_module) -> None:
        asked.append(True)
        os.kill(os.getpid(), signal.SIGTERM)
        signal.sigtimedwait([], 0)  # the handler runs here, inside llvmlite's callback
        return None  # nothing cached: the engine compiles the module

    raised_in_callback = []  # what Python prints as "Exception ignored"
    monkeypatch.setattr(sys, "unraisablehook", raised_in_callback.append)
    engine.set_object_cache(getbuffer_func=cached_object)
    engine.finalize_object()
    assert raised_in_callback == []
    assert asked and engine.get_function_address("seven") != 0
    assert stops.pending_stop() == signal.SIGTERM
    with pytest.raises(StopRequested, match="stopped by SIGTERM"):
        stops.raise_pending_stop()


class _StoppedWhileUnpickled:
    """Unpickled, it is stopped by SIGTERM: the handler runs inside the unpickling."""

    def __reduce__(self):
        return (_stopped_now, ())


def _stopped_now() -> str:
    os.kill(os.getpid(), signal.SIGTERM)
    signal.sigtimedwait([], 0)  # the handler runs here, inside numba's unpickling
    return "built"


def test_a_stop_inside_numbas_unpickling_is_remembered_not_raised(caught_stops):
    """A SIGTERM that lands while numba unpickles a cached kernel's constants (a callback
    from C, as one did while a run loaded a kernel) is raised at the next tick: raised
    there, the run ended with a SystemError instead of the stop."""
    import cloudpickle
    from numba.core.serialize import _numba_unpickle

    data = cloudpickle.dumps(_StoppedWhileUnpickled())
    assert _numba_unpickle(id(data), data, b"stop-test") == "built"
    assert stops.pending_stop() == signal.SIGTERM
    with pytest.raises(StopRequested, match="stopped by SIGTERM"):
        stops.raise_pending_stop()
