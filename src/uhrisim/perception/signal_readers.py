"""The ROV's readers of the diver's signals, one per channel, behind one call per sensor
reading (docs/hri.md, "Wiring").

* ``camera(frame, slate_near, diver_in_view)``: the slate's markers
  (:class:`~uhrisim.perception.markers.MarkerReader`, every frame; around where the
  slate is expected, given as (NED point, margin m), and in the whole picture every few
  frames) and gestures (:class:`~uhrisim.perception.gesture_reader.GestureReader`, at its
  own rate, in the pictures the ROV's track puts the diver in);
* ``ping(ping, range_m, bearing_rad)``: the two-arm wave (:class:`~uhrisim.perception.
  sonar_wave.SonarWaveReader`) around the tracked diver.

A slate held up is read in frame after frame: a command is said once, and again only
after ``repeat_s`` without it on that channel (or after another command was said on it),
so the counts of recognitions compare with the diver's signals one for one.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from uhrisim.perception.gesture_reader import GestureReader
from uhrisim.perception.markers import MarkerReader, marker_signals
from uhrisim.perception.signals import RecognizedSignal
from uhrisim.perception.sonar_wave import SonarWaveReader
from uhrisim.sensors.camera.camera import CameraFrame
from uhrisim.sensors.sonar.ping import SonarPing


@dataclass
class SignalReaders:
    """Markers, gestures and the sonar wave (module docstring); a reader set to None is
    off. ``said`` keeps every signal said, in order."""

    markers: MarkerReader | None = field(default_factory=MarkerReader)
    gestures: GestureReader | None = field(default_factory=GestureReader)
    sonar: SonarWaveReader | None = field(default_factory=SonarWaveReader)
    min_marker_confidence: float = 0.6
    repeat_s: float = 5.0
    said: list[RecognizedSignal] = field(default_factory=list)
    _last: dict[str, tuple[str, float]] = field(default_factory=dict)

    def camera(self, frame: CameraFrame, slate_near: tuple[NDArray[np.float64], float |
                                                           NDArray[np.float64]] | None = None,
               diver_in_view: bool = True) -> list[RecognizedSignal]:
        """The signals read in one camera frame; ``slate_near``: where the slate is
        expected (NED point, margin m), None if nowhere in particular; ``diver_in_view``:
        whether the ROV's track puts the diver in the picture (the gesture reader reads
        only pictures of him: :meth:`GestureReader.feed`)."""
        found: list[RecognizedSignal] = []
        if self.markers is not None:
            found += marker_signals(self.markers.read(frame, *(slate_near or (None,))),
                                    frame.t, self.min_marker_confidence)
        if self.gestures is not None:
            found += self.gestures.feed(frame.t, frame.rgb, diver_in_view)
        return self.once(found)

    def ping(self, ping: SonarPing, range_m: float | None, bearing_rad: float | None
             ) -> list[RecognizedSignal]:
        """The signals read in one ping, given the diver's range (m) and bearing (rad,
        > 0 starboard) in it, None if he is not tracked."""
        if self.sonar is None:
            return []
        return self.once(self.sonar.feed(ping, range_m, bearing_rad))

    def once(self, found: list[RecognizedSignal]) -> list[RecognizedSignal]:
        """The signals of ``found`` that are new (module docstring); kept in ``said``."""
        out = []
        for signal in found:
            text = str(signal.command)
            last = self._last.get(signal.channel)
            repeated = last is not None and last[0] == text
            if repeated and signal.t - last[1] < self.repeat_s:
                self._last[signal.channel] = (text, signal.t)  # still held up: still quiet
                continue
            self._last[signal.channel] = (text, signal.t)
            out.append(signal)
        self.said += out
        return out
