"""What the help says: every accepted input, the frame and signs, paper labels explained.

And the options it promises: ``track`` takes the analysis's ``--method`` and
``--false-alarm-rate``; ``inject`` takes amplitudes in dB relative to a level the user
knows (the median over the pulses of the strongest sample's modulus).
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from sarmotion.cli.main import COMMANDS, run
from sarmotion.io import load_traces
from sarmotion.simulation import builtin_scene_names

#: Commands whose INPUTS are read by the input dispatch (sarmotion.cli.inputs).
INPUT_COMMANDS = ("image", "analyze", "track", "separate", "convert", "inject")

#: Commands that print or write positions and speeds.
FRAME_COMMANDS = ("image", "analyze", "track", "inject", "demo")

#: A LaTeX label of the paper: eq:image, sect:RPCA, fig:setup, ...
LABEL = re.compile(r"\b(?:eq|sect|fig|thm|alg|app|lem):[A-Za-z]")


def _help(capsys, *cmd: str) -> str:
    assert run([*cmd, "--help"]) == 0
    return " ".join(capsys.readouterr().out.split())


@pytest.mark.parametrize("cmd", INPUT_COMMANDS)
def test_help_lists_every_accepted_input(cmd, capsys):
    text = _help(capsys, cmd)
    for kind in ("built-in scene", ".toml", ".h5", "GOTCHA .mat", "directory of them", ".cphd"):
        assert kind in text, (cmd, kind)
    for name in builtin_scene_names():
        assert name in text, (cmd, name)


@pytest.mark.parametrize("cmd", FRAME_COMMANDS)
def test_help_states_the_axes_and_the_sign_of_a_range_speed(cmd, capsys):
    text = _help(capsys, cmd)
    assert "x is range" in text and "y is cross range" in text
    assert "positive towards the radar" in text


@pytest.mark.parametrize("cmd", [(), *((c,) for c in COMMANDS)])
def test_paper_labels_are_said_to_be_the_papers(cmd, capsys):
    """Each label is said to be the paper's: nearby, or by the help's note on labels."""
    text = _help(capsys, *cmd)
    glossed = "name equations and sections of the paper" in text
    for m in LABEL.finditer(text):
        before = text[max(0, m.start() - 40) : m.start()].lower()
        near = "paper" in before or "label" in before
        assert glossed or near, (cmd, text[m.start() - 40 : m.end() + 10])


def test_track_takes_the_analysis_method_and_false_alarm_rate_and_says_why_no_track(
    tmp_path, capsys
):
    """One 1-degree sub-aperture: its detections cannot form a track, and the console says so."""
    text = _help(capsys, "track")
    assert "--method" in text and "--false-alarm-rate" in text
    out = tmp_path / "t"
    bad = ["track", "scene1", "--out", str(out), "--false-alarm-rate", "2"]
    assert run(bad) == 2
    assert "--false-alarm-rate" in capsys.readouterr().err
    args = ["track", "scene1", "--out", str(out), "--workers", "0", "--size", "40"]
    assert run([*args, "--method", "rpca", "--false-alarm-rate", "0.001"]) == 0
    said = capsys.readouterr().out
    doc = json.loads((out / "tracks.json").read_text())
    assert doc["options"]["analysis"]["method"] == "rpca"
    assert doc["options"]["analysis"]["false_alarm_rate"] == 0.001
    n_detections = sum(s["n_detections"] for s in doc["sub_apertures"])
    assert len(doc["sub_apertures"]) == 1 and n_detections >= 1 and not doc["tracks"]
    assert f"{n_detections} detection(s) in 1 sub-aperture(s)" in said
    assert "a track needs at least 2 detections" in said


def test_inject_amplitude_in_db_is_relative_to_a_typical_pulses_strongest_echo(tmp_path):
    """``AMP`` with a dB suffix: 0dB is the default, -20dB a tenth of its amplitude.

    The default is the median over the pulses of max|D|; a lone target injected at 0dB
    into silent traces has that as its own median max|D| (a unit-reflectivity point's
    range-compressed peak is 1 on every pulse), to within the peak's sampling loss.
    """
    base = tmp_path / "base.h5"
    assert run(["simulate", "hyperbola", "--out", str(base)]) == 0
    clutter = load_traces(base)
    level = float(np.median(np.abs(clutter.data).max(axis=1)))
    parts = {}
    for amp in ("", ",0dB", ",-20dB", f",{level / 10:.17g}"):
        out = tmp_path / f"i{len(parts)}.h5"
        assert run(["inject", str(base), "--target", f"3,-4,5,2{amp}", "--out", str(out)]) == 0
        parts[amp] = load_traces(out).data - clutter.data
    np.testing.assert_allclose(parts[",0dB"], parts[""], rtol=1e-12, atol=0)
    np.testing.assert_allclose(parts[",-20dB"], parts[""] / 10.0, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(parts[f",{level / 10:.17g}"], parts[",-20dB"], rtol=1e-9)
    peak = float(np.median(np.abs(parts[",0dB"]).max(axis=1)))
    assert peak == pytest.approx(level, rel=0.1)
