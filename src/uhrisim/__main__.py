"""``python -m uhrisim`` is the ``uhrisim`` command."""

from uhrisim.cli import app

app(prog_name="uhrisim")
