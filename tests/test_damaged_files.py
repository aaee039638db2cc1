"""Run files whose bytes changed after they were written: the record datasets carry HDF5's
Fletcher-32 checksum per chunk, so a changed byte in the records is an error naming the dataset
and its rows (never records read back altered), and files written before checksums still read
and resume."""

from __future__ import annotations

import copy
import shutil

import h5py
import numpy as np
import pytest
from fuzz_support import BASE, clean_error, cli, listing, to_toml

import emorbit
from emorbit.errors import InputError

#: the fuzz's point mass alone, 100 steps, a checkpoint every 50
SCENE = copy.deepcopy(BASE)
SCENE["body"] = SCENE["body"][:1]
SCENE["integrator"].update({"t_end": "46.4758 s", "output_every": 1, "checkpoint_every": 50})


@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    folder = tmp_path_factory.mktemp("run")
    (folder / "s.toml").write_text(to_toml(SCENE))
    code, _, err = cli(["run", folder / "s.toml", "-o", folder / "run.h5", "-q"])
    assert code == 0, err
    return folder / "run.h5"


def _flip(path, dataset: str, at: int = 100) -> int:
    """Change one byte inside the first chunk of ``dataset``; return its file offset."""
    with h5py.File(path, "r") as f:
        offset = f[dataset].id.get_chunk_info(0).byte_offset + at
    raw = bytearray(path.read_bytes())
    raw[offset] ^= 0x10
    path.write_bytes(bytes(raw))
    return offset


def test_record_datasets_carry_checksums(run_file):
    with h5py.File(run_file, "r") as f:
        for name in ("time", "invariants/energy", "bodies/sat/position", "checkpoint/point/x"):
            assert f[name].fletcher32, name


@pytest.mark.parametrize("dataset", ["bodies/sat/position", "time", "invariants/energy"])
def test_a_flipped_byte_in_the_records_is_detected_on_read(tmp_path, run_file, dataset):
    """Before, 15 of 156 damaged files read, plotted or resumed with altered past records and no
    complaint: no dataset carried a checksum."""
    path = tmp_path / "run.h5"
    shutil.copy(run_file, path)
    _flip(path, dataset)
    with pytest.raises(InputError, match=rf"damaged: dataset /{dataset}, rows 0 to 100, .*Fletcher-32"):
        emorbit.read(path)
    before = path.read_bytes()
    code, _, err = cli(["resume", path, "--t-end", "92.9516 s", "-q"])
    assert clean_error(code, err) == "file" and f"/{dataset}" in err and "checksum" in err
    assert path.read_bytes() == before and listing(tmp_path) == {"run.h5"}


def _strip_checksums(path) -> None:
    """Rewrite every dataset without its checksum, as emorbit wrote files before checksums."""
    with h5py.File(path, "r+") as f:
        found = []
        f.visititems(lambda n, o: found.append(n) if isinstance(o, h5py.Dataset) and o.fletcher32 else None)
        for name in found:
            ds = f[name]
            data, attrs, chunks, maxshape = ds[()], dict(ds.attrs), ds.chunks, ds.maxshape
            growable = maxshape[0] is None
            del f[name]
            new = f.create_dataset(name, data=data, chunks=chunks if growable else None, maxshape=maxshape)
            new.attrs.update(attrs)
            assert not new.fletcher32


def test_a_file_without_checksums_reads_and_resumes_as_before(tmp_path, run_file):
    plain, checked = tmp_path / "plain.h5", tmp_path / "checked.h5"
    shutil.copy(run_file, plain)
    shutil.copy(run_file, checked)
    _strip_checksums(plain)
    a, b = emorbit.read(plain).si, emorbit.read(checked).si
    assert np.array_equal(a.bodies["sat"]["position"], b.bodies["sat"]["position"])
    for path in (plain, checked):
        code, _, err = cli(["resume", path, "--t-end", "92.9516 s", "-q"])
        assert code == 0, err
    a, b = emorbit.read(plain).si, emorbit.read(checked).si
    assert len(a) == len(b) == 201
    for name in ("time", "energy", "momentum"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    assert np.array_equal(a.bodies["sat"]["position"], b.bodies["sat"]["position"])


def test_a_damaged_name_is_not_taken_for_a_file_of_an_earlier_version(tmp_path, run_file):
    """A changed byte in the name /diagnostics/stalled_solves made the file look like one of an
    earlier version that lacks the dataset: resume went on, filled its rows with zeros and left
    the damaged dataset beside them (exit 0)."""
    path = tmp_path / "run.h5"
    shutil.copy(run_file, path)
    with h5py.File(path, "r+") as f:
        f.move("diagnostics/stalled_solves", "diagnostics/stalked_solves")
    with pytest.raises(InputError, match="stalked_solves is not a dataset emorbit writes"):
        emorbit.read(path)
    code, _, err = cli(["resume", path, "--t-end", "92.9516 s", "-q"])
    assert clean_error(code, err) == "file" and "stalked_solves" in err


def test_probe_finds_a_file_that_stalls_the_hdf5_library(tmp_path, run_file, monkeypatch):
    """emorbit.read(probe=...) reads the file in a child process first: a file whose reading does
    not end there (the HDF5 library loops on some damaged attribute heaps, where no error
    reaches Python) is an InputError saying so; without the probe the file is read as ever."""
    import emorbit.io.reader as reader

    monkeypatch.setattr(reader, "_PROBE", "import time\ntime.sleep(60)\n")
    with pytest.raises(InputError, match="does not end within 1 s"):
        emorbit.read(run_file, probe=1.0)
    assert len(emorbit.read(run_file)) == 101


def test_plot_reads_through_the_probe(tmp_path, run_file, monkeypatch):
    """``emorbit plot`` reads each run file through the probe: a file whose reading crashes the
    HDF5 library (here a probe that kills itself) is an error naming it (exit 2), not a crash
    of the plot itself."""
    import emorbit.io.reader as reader
    from emorbit.cli import main

    monkeypatch.setattr(reader, "_PROBE", "import os, signal\nos.kill(os.getpid(), signal.SIGSEGV)\n")
    assert main(["plot", str(run_file), "-o", str(tmp_path / "fig.png")]) == 2
    assert not (tmp_path / "fig.png").exists()
