"""An outside helm that does not drive its agent is said, once and then at most every
``repeat_s``, naming the variable and its value (uhrisim.bridges.helm_watch). The values
are pHelmIvP's (MOOS-IvP pHelmIvP/HelmIvP.cpp: postHelmStatus posts IVPHELM_STATE every
iteration, postAllStop posts IVPHELM_ALLSTOP when its message changes)."""

from __future__ import annotations

import pytest

from uhrisim.bridges.helm_watch import HelmSilentError, OutsideHelmWatch
from uhrisim.scenario.schema import HelmWatchSection

WHO = "MOOS community 'videoray'"


def watch(**settings) -> tuple[OutsideHelmWatch, list[str]]:
    said: list[str] = []
    w = OutsideHelmWatch(WHO, "DESIRED_*", HelmWatchSection(**settings), said.append,
                         hint=lambda state: f" [state {state}]")
    w.start(0.0)
    return w, said


def run(w: OutsideHelmWatch, until: float, dt: float = 0.25, helm=None) -> None:
    """Check every ``dt`` s from the last check to ``until``; ``helm(t)`` posts first."""
    t = getattr(w, "_t", 0.0)
    while t < until - 1e-9:
        t += dt
        if helm is not None:
            helm(w, t)
        w.check(t)
    w._t = t


def test_malconfig_is_said_at_once_and_then_every_repeat():
    w, said = watch(silence_s=10.0, repeat_s=5.0)
    w.helm_status("IVPHELM_STATE", "MALCONFIG", 0.5)
    w.helm_status("BHV_ERROR", "Problem with line 21", 0.5)
    run(w, 12.0)
    assert said[0] == (f"{WHO}: IVPHELM_STATE=MALCONFIG — pHelmIvP rejected its configuration "
                       "(its behavior file, domain or settings); see its console "
                       "(BHV_ERROR=Problem with line 21)")
    assert len(said) == 3  # t = 0.5 (first check after it), 5.5, 10.5
    summary = w.summary(12.0)
    assert summary["helm_state"] == "MALCONFIG" and summary["helm_states_seen"] == {
        "MALCONFIG": 0.5}
    assert summary["helm_messages"] == ["BHV_ERROR=Problem with line 21"]
    assert summary["first_command_s"] is None and summary["seconds_without_commands"] == 12.0
    assert summary["warnings"] == 3 and summary["last_warning"] == said[-1]


def test_an_allstop_that_lasts_is_said_a_passing_one_is_not():
    w, said = watch(silence_s=10.0)

    def helm(w, t):  # driving; all-stop at start-up (one iteration), then a lasting one
        w.helm_status("IVPHELM_STATE", "DRIVE", t)
        w.command(t)
        stop = "MissingDecVars:speed,course" if t <= 0.25 else (
            "NothingToDo" if t >= 20.0 else "clear")
        w.helm_status("IVPHELM_ALLSTOP", stop, t)

    run(w, 29.75, helm=helm)
    assert said == []
    run(w, 30.0, helm=helm)
    assert said == [f"{WHO}: IVPHELM_ALLSTOP=NothingToDo for 10 s — pHelmIvP drives but "
                    "decides nothing"]
    assert w.summary(30.0)["allstops"]["NothingToDo"] == 41


def test_a_parked_helm_is_told_how_to_deploy():
    w, said = watch(silence_s=10.0)
    run(w, 10.0, helm=lambda w, t: w.helm_status("IVPHELM_STATE", "PARK", t))
    assert said == [f"{WHO}: IVPHELM_STATE=PARK for 10 s — the helm is parked: deploy it "
                    "with MOOS_MANUAL_OVERRIDE=false (uPokeDB, pMarineViewer's DEPLOY)"]


def test_silence_after_the_helm_drove_and_the_seconds_without_commands():
    w, said = watch(silence_s=10.0, repeat_s=5.0)

    def helm(w, t):
        if t <= 20.0 or t > 60.0:  # drives, stops for 40 s, drives again
            w.command(t)

    run(w, 80.0, helm=helm)
    assert said == [f"{WHO}: no DESIRED_* since t=20.0 s (10 s) [state None]",
                    f"{WHO}: no DESIRED_* since t=20.0 s (15 s) [state None]",
                    f"{WHO}: no DESIRED_* since t=20.0 s (20 s) [state None]",
                    f"{WHO}: no DESIRED_* since t=20.0 s (25 s) [state None]",
                    f"{WHO}: no DESIRED_* since t=20.0 s (30 s) [state None]",
                    f"{WHO}: no DESIRED_* since t=20.0 s (35 s) [state None]",
                    f"{WHO}: no DESIRED_* since t=20.0 s (40 s) [state None]"]
    summary = w.summary(80.0)
    assert summary["seconds_without_commands"] == pytest.approx(40.25)
    assert summary["first_command_s"] == 0.25


def test_a_helm_that_never_drives_is_silent_for_the_whole_run():
    w, said = watch(silence_s=10.0, repeat_s=30.0)
    run(w, 100.0)
    assert said[0] == f"{WHO}: no DESIRED_* since the start (10 s) [state None]"
    assert len(said) == 4  # 10, 40, 70, 100 s
    assert w.summary(100.0)["seconds_without_commands"] == 100.0


def test_a_link_down_is_said_before_what_it_hides():
    w, said = watch(silence_s=10.0)
    w.connection(False, 0.0, "retrying 127.0.0.1:9000 (last error: refused)")
    run(w, 10.0)
    assert said == [f"{WHO}: not connected for 10 s (retrying 127.0.0.1:9000 (last error: "
                    "refused))"]


def test_required_ends_the_run_at_the_first_problem():
    w, said = watch(required=True)
    w.helm_status("IVPHELM_STATE", "MALCONFIG", 1.0)
    with pytest.raises(HelmSilentError, match=r"MALCONFIG .* requires its outside helm"):
        w.check(1.0)
    assert said == []


def test_nothing_is_said_while_the_helm_drives():
    w, said = watch(silence_s=1.0)

    def helm(w, t):
        w.helm_status("IVPHELM_STATE", "DRIVE", t)
        w.helm_status("IVPHELM_ALLSTOP", "clear", t)
        w.command(t)

    run(w, 600.0, helm=helm)
    assert said == [] and w.summary(600.0)["seconds_without_commands"] == 0.0
