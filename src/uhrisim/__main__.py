"""``python -m uhrisim`` is the ``uhrisim`` command (:func:`entry`, also the console
script)."""

import sys


def entry() -> int:
    """The command, with a Ctrl-C while it is still starting (importing) said in one line
    as later ones are: ``error: interrupted``, exit status 130."""
    try:
        from uhrisim.cli import main

        return main()
    except KeyboardInterrupt:
        sys.stderr.write("error: interrupted\n")
        return 130


if __name__ == "__main__":
    sys.exit(entry())
