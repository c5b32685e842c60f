"""Progress lines for logs and pipes (uhrisim.app.progress): when a line is written, and
its numbers (share done, real-time factor, time left) on a scripted clock."""

import pytest

from uhrisim.app.progress import ProgressLines, duration_text


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_a_line_first_then_every_period_then_at_the_end():
    clock, lines = Clock(), []
    bar = ProgressLines("mission", 600.0, "s simulated", lines.append, every_s=10.0,
                        simulated=True, clock=clock)
    bar.update(0.0)  # setup done: the rates count from here
    for second in range(1, 31):  # 4 simulated seconds per wall second
        clock.now += 1.0
        bar.update(4.0 * second)
    bar.finish()
    assert lines == [
        "mission: 0/600 s simulated (0 %)",
        "mission: 40/600 s simulated (7 %), 4.0x real time, about 2 min 20 s left",
        "mission: 80/600 s simulated (13 %), 4.0x real time, about 2 min 10 s left",
        "mission: 120/600 s simulated (20 %), 4.0x real time, about 2 min 00 s left",
    ]
    bar.finish()  # nothing new: no second last line
    assert len(lines) == 4


def test_counts_with_a_total_known_late_and_the_final_line():
    clock, lines = Clock(), []
    bar = ProgressLines("sweep", None, "runs", lines.append, every_s=5.0, clock=clock)
    bar.update(0)
    clock.now += 2.0
    bar.update(1, 8)  # within the period: no line
    clock.now += 6.0
    bar.update(4, 8)
    clock.now += 1.0
    bar.update(8, 8)
    bar.finish()
    assert lines == ["sweep: 0 runs",
                     "sweep: 4/8 runs (50 %), 0.5 runs/s, about 8 s left",
                     "sweep: 8/8 runs (100 %), 0.89 runs/s"]


@pytest.mark.parametrize(("seconds", "text"), [(0.4, "0 s"), (59.6, "1 min 00 s"),
                                               (185, "3 min 05 s"), (3720, "1 h 02 min")])
def test_duration_text(seconds, text):
    assert duration_text(seconds) == text
