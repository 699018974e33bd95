"""Any input through one dispatch: sarmotion.read / sarmotion.open, sarmotion.io.read_files."""

from __future__ import annotations

import sys

import numpy as np
import pytest

import sarmotion
from sarmotion._lazy import attach
from sarmotion.io import DataError, file_kind, open_blocks, read_files, read_native, save_traces
from sarmotion.io.gotcha import write_gotcha
from sarmotion.sources import open_source, read_source


def _all_pulses(source) -> np.ndarray:
    return np.concatenate([b for _, _, b in source.blocks(64)])


def test_every_kind_reads_the_same_traces_whole_and_by_blocks(tmp_path):
    """A scene written as native and GOTCHA files reads back to the same data either way."""
    traces = sarmotion.read("hyperbola")
    native = tmp_path / "t.h5"
    save_traces(native, traces)
    gotcha = tmp_path / "g"
    write_gotcha(traces, gotcha, pulses_per_file=traces.n_pulses // 2 + 1)
    assert file_kind(native) == ("native", [str(native)])
    kind, files = file_kind(gotcha)
    assert kind == "gotcha" and len(files) == 2
    for path in (native, gotcha):
        whole = sarmotion.read(path)
        blocks = sarmotion.open(path)
        assert whole.n_pulses == blocks.n_pulses == traces.n_pulses
        np.testing.assert_array_equal(_all_pulses(blocks), whole.data)
        # GOTCHA stores complex64 samples: the data agree to float32 rounding
        scale = np.abs(traces.data).max()
        assert np.abs(whole.data - traces.data).max() <= 1e-6 * scale
    np.testing.assert_array_equal(read_native(native).data, read_files([native]).data)
    assert open_blocks(native).n_pulses == traces.n_pulses


def test_a_scene_opens_as_blocks_of_its_simulation():
    src = sarmotion.open("hyperbola")
    np.testing.assert_array_equal(_all_pulses(src), sarmotion.read("hyperbola").data)


@pytest.mark.parametrize(
    ("inputs", "message"),
    [
        ([], "no INPUT given"),
        (["missing.h5"], "input not found"),
        (["notes.txt"], "cannot read"),
    ],
)
def test_bad_inputs_are_one_line_data_errors(tmp_path, monkeypatch, inputs, message):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "notes.txt").write_text("x")
    with pytest.raises(DataError, match=message):
        sarmotion.read(inputs)


def test_kinds_do_not_mix_and_cphd_options_need_cphd(tmp_path):
    traces = sarmotion.read("hyperbola")
    save_traces(tmp_path / "a.h5", traces)
    save_traces(tmp_path / "b.h5", traces)
    with pytest.raises(DataError, match="one native traces"):
        read_files([tmp_path / "a.h5", tmp_path / "b.h5"])
    with pytest.raises(DataError, match="CPHD"):
        read_files(tmp_path / "a.h5", vectors=(0, 10))


def test_the_namespace_lists_public_names_only():
    names = dir(sarmotion)
    assert {"read", "open", "analyze", "Traces", "__version__"} <= set(names)
    assert not [n for n in names if n in ("TYPE_CHECKING", "import_module", "annotations")]
    assert not [n for n in names if n.startswith("_") and n != "__version__"]
    assert set(names) == set(sarmotion.__all__)


def test_read_source_keeps_a_scenes_truth_and_files_have_none(tmp_path):
    traces, sim = read_source("hyperbola")
    assert sim is not None and sim.traces is traces
    save_traces(tmp_path / "t.h5", traces)
    again, none = read_source([tmp_path / "t.h5"])
    assert none is None and again.n_pulses == traces.n_pulses
    assert open_source(tmp_path / "t.h5").n_pulses == traces.n_pulses


def test_attach_imports_a_name_once_and_lists_only_public_names(monkeypatch):
    import types

    module = types.ModuleType("sarmotion_lazy_probe")
    module.__package__ = "sarmotion"
    monkeypatch.setitem(sys.modules, module.__name__, module)
    getattr_, dir_ = attach(module.__name__, {"read_source": ".sources"}, eager=("x",))
    assert dir_() == ["read_source", "x"]
    assert getattr_("read_source") is read_source
    assert module.read_source is read_source  # cached in the namespace
    with pytest.raises(AttributeError, match="no attribute 'missing'"):
        getattr_("missing")
