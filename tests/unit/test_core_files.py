"""``core.files.write_text_whole``: a file written beside and renamed into place, so that a
reader (a restarted sweep reading ``metrics.json``) or a kill mid-write never sees a part."""

from __future__ import annotations

import pytest

from uhrisim.core.files import write_text_whole


def test_a_reader_of_the_old_file_keeps_it_whole_and_the_new_one_replaces_it(tmp_path):
    path = tmp_path / "metrics.json"
    path.write_text('{"completed": false}\n')
    with path.open() as reader:  # opened before the write: the old file, whole
        assert write_text_whole(path, '{"completed": true}\n') == path
        assert reader.read() == '{"completed": false}\n'
    assert path.read_text() == '{"completed": true}\n'
    assert sorted(p.name for p in tmp_path.iterdir()) == ["metrics.json"]


def test_a_failed_write_leaves_the_old_file_and_no_part(tmp_path):
    path = tmp_path / "metrics.json"
    path.write_text("old\n")
    with pytest.raises(UnicodeEncodeError):  # fails after the part file was opened
        write_text_whole(path, "new \ud800\n")
    assert path.read_text() == "old\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["metrics.json"]
