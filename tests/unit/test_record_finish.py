"""A recording cut by a full disk is completed where it lies (summary and footer appended
after its last whole record): mcap's seeking reader and rosbags read every message the
copy that ``recover`` makes holds, wherever the cut falls; under a file-size limit the
data stop short of it, leaving the summary room."""

import resource
import shutil
import subprocess
import sys

import pytest
from mcap.reader import make_reader
from rosbags.highlevel import AnyReader

from uhrisim.core.errors import UhrisimError
from uhrisim.record.finish import (
    HEADROOM_BYTES,
    finish_in_place,
    headroom_path,
    size_limit_with_headroom,
)
from uhrisim.record.mcap_recorder import McapRecorder
from uhrisim.record.recover import recover
from uhrisim.record.rosbag2 import write_metadata


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    """200 clock messages and 50 events in small chunks, with metadata records."""
    path = tmp_path_factory.mktemp("rec") / "recording.mcap"
    with McapRecorder(path, chunk_size=2000, metadata={"run": {"seed": "1"}}) as rec:
        assert headroom_path(path).stat().st_size == HEADROOM_BYTES
        for i in range(200):
            rec.write_clock(i * 0.1)
            if i % 4 == 0:
                rec.write_event(i * 0.1, "note", f"event {i}")
    assert not headroom_path(path).exists()  # given back on close
    return path


def messages(path):
    with path.open("rb") as f:
        reader = make_reader(f)
        return reader.get_summary(), [(c.topic, m.log_time, m.data)
                                      for _, c, m in reader.iter_messages()]


@pytest.mark.parametrize("keep", [0.98, 0.5, 0.2])  # in the summary, in the data
def test_a_cut_recording_finished_in_place_reads_as_the_recovered_copy(recording, tmp_path,
                                                                       keep):
    bag = tmp_path / "bag"
    bag.mkdir()
    cut = bag / "recording.mcap"
    shutil.copy(recording, cut)
    with cut.open("r+b") as f:  # anywhere: mid-record, between a chunk and its indexes
        f.truncate(int(recording.stat().st_size * keep))
    recover(cut, tmp_path / "copy.mcap")
    count = finish_in_place(cut)
    summary, finished = messages(cut)
    _, copied = messages(tmp_path / "copy.mcap")
    assert count == len(finished) == len(copied) > 0
    assert sorted(finished) == sorted(copied)
    assert summary.statistics.message_count == count
    assert summary.statistics.chunk_count == len(summary.chunk_indexes) > 1
    assert len(summary.metadata_indexes) == 1
    write_metadata(cut)
    with AnyReader([bag]) as reader:  # an independent reader, metadata.yaml and all
        assert reader.message_count == count
    with pytest.raises(UhrisimError, match="complete already"):
        finish_in_place(cut)


def test_under_a_file_size_limit_the_data_stop_short_of_it():
    """Asked in a child process: the limit is the process's own."""
    limit = 3 * 1024 * 1024
    code = ("import resource; from uhrisim.record.finish import size_limit_with_headroom; "
            f"resource.setrlimit(resource.RLIMIT_FSIZE, ({limit}, {limit})); "
            "print(size_limit_with_headroom())")
    said = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True).stdout
    assert int(said) == limit - limit // 4
    if resource.getrlimit(resource.RLIMIT_FSIZE)[0] == resource.RLIM_INFINITY:
        assert size_limit_with_headroom() is None
