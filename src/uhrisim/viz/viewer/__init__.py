"""Live web viewer: watch, steer and replay a mission in a browser (served on 127.0.0.1).

``ViewerServer`` serves the page and streams frames published by the simulation;
``serve_replay`` serves the same page over an MCAP recording with a time slider.
Needs the optional ``websockets`` package (``pip install uhrisim[viewer]``).
See docs/viewer.md for the frame and scene schemas.
"""

from __future__ import annotations

from uhrisim.viz.viewer.adapt import FrameBuilder, scene_from_world
from uhrisim.viz.viewer.hook import ViewerHook, attach_viewer
from uhrisim.viz.viewer.protocol import SPEED_CHOICES, Command, parse_command
from uhrisim.viz.viewer.server import ViewerServer

__all__ = [
    "SPEED_CHOICES",
    "Command",
    "FrameBuilder",
    "ViewerHook",
    "ViewerServer",
    "attach_viewer",
    "parse_command",
    "scene_from_world",
    "serve_replay",
]


def __getattr__(name: str):  # lazy: replay pulls in mcap readers only when used
    if name == "serve_replay":
        from uhrisim.viz.viewer.replay import serve_replay

        return serve_replay
    raise AttributeError(name)
