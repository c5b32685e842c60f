"""What the command-line tests expect of a refused input: one line, ``error: ...``, exit
status 2 (used by tests/integration/test_cli_bad_input.py and tests/unit/test_batch_files.py)."""

from __future__ import annotations


def one_line_error(result, *parts: str) -> str:
    assert result.exit_code == 2, result.output
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), result.output
    for part in parts:
        assert part in lines[0], lines[0]
    return lines[0]
