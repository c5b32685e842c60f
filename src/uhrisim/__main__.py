"""``python -m uhrisim`` is the ``uhrisim`` command (:func:`entry`, also the console
script)."""

import sys


def entry() -> int:
    """The command, with a stop signal while it is still starting (importing) said in one
    line as later ones are (``error: interrupted``, exit status 130; SIGTERM 143)."""
    from uhrisim.core.errors import StopRequested
    from uhrisim.core.stops import catch_stop_signals, stop_message, stop_signum

    catch_stop_signals()
    try:
        from uhrisim.cli import main

        return main()
    except (KeyboardInterrupt, StopRequested) as stop:
        signum = stop_signum(stop)
        sys.stderr.write(f"error: {stop_message(signum)}\n")
        return 128 + signum


if __name__ == "__main__":
    sys.exit(entry())
