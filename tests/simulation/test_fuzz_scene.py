"""Fuzzing scene files through ``sarmotion simulate``: exit 0 or 2, one line, nothing left.

The file mutated is a tiny valid scene (16 pulses of 32 samples, two targets), so that a
mutant that stays valid simulates in milliseconds. Each mutant, drawn from a seeded
generator (:data:`SEED`), is one of

* a value replaced: any key of the schema (top level, trajectory of either kind, radar,
  a target) set to zero, a negative, a denormal (1e-320), a huge or overflowing number
  (1e30, 1e308, 1e400 = inf), inf, nan, the 64-bit integer extremes, a string, a
  boolean, a date, an empty or wrong-length array, a nested array or an inline table;
* a structural edit: a line deleted or repeated, the text cut short, an unknown key,
  arrays, inline tables or dotted keys nested 5 to 5000 deep, brackets inserted,
  bytes that are not UTF-8, the trajectory turned linear (with its own keys);
* several of these at once.

For every mutant the command must, within :data:`fuzzing.TIME_LIMIT_S`,

* exit 0 or 2 (never 1, an internal error, and never raise);
* on exit 2, print exactly one line on stderr, and leave nothing at ``--out``;
* on exit 0, print nothing on stderr and write traces that the native reader accepts
  (what ``simulate`` writes, the project's readers read).
"""

from __future__ import annotations

import math
import re
import signal
from pathlib import Path

import numpy as np
import pytest

from fuzzing import TIME_LIMIT_S, Hang
from sarmotion.cli.main import run
from sarmotion.io import load_traces

SEED = 45
N_MUTANTS = 200

BASE = """schema = "sarmotion.scene/1"
name = "fuzz"
description = "two targets"
reference_point_m = [1.0, 2.0]

[radar]
carrier_hz = 9.6e9
bandwidth_hz = 100e6
n_samples = 32
frequency_step_hz = 4e6
pulse = "rect"

[trajectory]
kind = "circular"
aperture_deg = 0.2
altitude_m = 7300.0
ground_radius_m = 7100.0
speed_mps = 70.0
pulses_per_deg = 80.0
centre_azimuth_deg = 0.0
n_pulses = 16

[[targets]]
position_m = [3.0, -4.0]
amplitude = 1.0
phase_deg = 0.0
label = "a"

[[targets]]
position_m = [-10.0, 6.0]
velocity_mps = [2.0, 1.0]
amplitude = 0.5
phase_deg = 30.0
label = "b"
"""

LINEAR = """[trajectory]
kind = "linear"
centre_m = [7000.0, 0.0, 7000.0]
direction = [0.0, 1.0, 0.0]
speed_mps = 70.0
aperture_m = 16.0
pulse_spacing_m = 1.0
"""

HOSTILE = [
    "0",
    "-1",
    "1e-320",
    "1e30",
    "1e308",
    "1e400",
    "inf",
    "-inf",
    "nan",
    str(2**63 - 1),
    str(-(2**63)),
    '"text"',
    "true",
    "1979-05-27T07:32:00Z",
    "[]",
    "[1.0]",
    "[1.0, 2.0, 3.0, 4.0]",
    "[[1.0, 2.0]]",
    "{ a = 1 }",
    "[1e308, 1e308]",
    "[1e30, -1e30, 1e30]",
    '["a", "b"]',
    "0.5",
    "3",
]


def _lines_with_values(text: str) -> list[int]:
    return [i for i, line in enumerate(text.splitlines()) if " = " in line]


def _mutate_once(text: str, rng: np.random.Generator) -> str:
    text = text or "\n"  # cut to nothing by an earlier mutation
    lines = text.splitlines() or [""]
    kind = int(rng.integers(12))
    valued = _lines_with_values(text)
    if kind <= 4 and valued:  # a value replaced
        i = int(rng.choice(valued))
        key = lines[i].split(" = ")[0]
        lines[i] = f"{key} = {HOSTILE[int(rng.integers(len(HOSTILE)))]}"
    elif kind <= 5:  # a line deleted or repeated
        i = int(rng.integers(len(lines)))
        if rng.random() < 0.5:
            del lines[i]
        else:
            lines.insert(i, lines[i])
    elif kind == 6:  # cut short
        return text[: int(rng.integers(len(text)))]
    elif kind == 7:  # an unknown key in some table
        i = int(rng.integers(len(lines) + 1))
        lines.insert(i, "colour = 3")
    elif kind == 8:  # deep nesting: arrays, inline tables or dotted keys
        depth = int(rng.choice([5, 9, 50, 600, 5000]))
        how = int(rng.integers(3))
        if how == 0:
            deep = "x = " + "[" * depth + "1" + "]" * depth
        elif how == 1:
            deep = "x = " + "{ a = " * depth + "1" + " }" * depth
        else:
            deep = "x." + ".".join(["a"] * depth) + " = 1"
        lines.insert(int(rng.integers(len(lines) + 1)), deep)
    elif kind == 9:  # a bracket inserted anywhere
        pos = int(rng.integers(len(text)))
        return text[:pos] + str(rng.choice(list("[]{}"))) + text[pos:]
    elif kind == 10:  # not UTF-8
        pos = int(rng.integers(len(text)))
        return text[:pos] + "\udcff" + text[pos:]
    else:  # the trajectory turned linear
        start = text.find("[trajectory]")
        end = text.find("[[targets]]", start)
        if start < 0 or end < 0:  # cut or deleted by an earlier mutation
            return text + "\n" + LINEAR
        return text[:start] + LINEAR + "\n" + text[end:]
    return "\n".join(lines) + "\n"


def mutants(seed: int, n: int) -> list[str]:
    """``n`` mutants of :data:`BASE` (1 to 3 mutations each), from ``seed``."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        text = BASE
        for _ in range(int(rng.integers(1, 4))):
            text = _mutate_once(text, rng)
        out.append(text)
    return out


def _alarm(signum, frame):
    raise Hang(f"simulate took more than {TIME_LIMIT_S:g} s")


def _simulate(args: list[str]) -> int:
    previous = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, TIME_LIMIT_S)
    try:
        return run(args)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)


def test_the_base_scene_simulates(tmp_path):
    path = tmp_path / "base.toml"
    path.write_text(BASE)
    assert run(["simulate", str(path), "--out", str(tmp_path / "t.h5")]) == 0
    assert load_traces(tmp_path / "t.h5").data.shape == (16, 32)


def test_mutated_scene_files_exit_0_or_2_in_one_line_leaving_nothing(tmp_path, capsys):
    import sarmotion.cli.simulate  # noqa: F401  (the command's imports, outside the time limit)

    counts = {0: 0, 2: 0}
    for k, text in enumerate(mutants(SEED, N_MUTANTS)):
        path = tmp_path / f"m{k}.toml"
        path.write_bytes(text.encode("utf-8", "surrogateescape"))
        gotcha = k % 4 == 3  # a quarter written as GOTCHA files into a directory
        out = tmp_path / (f"o{k}" if gotcha else f"o{k}.h5")
        capsys.readouterr()
        rc = _simulate(["simulate", str(path), "--out", str(out)])
        err = capsys.readouterr().err
        assert rc in (0, 2), (k, rc, err, text)
        counts[rc] += 1
        if rc == 2:
            assert err.count("\n") == 1 and err.startswith("sarmotion: error: "), (k, err)
            assert not out.exists(), (k, err)
        else:
            assert err == "", (k, err, text)
            if not gotcha:
                load_traces(out)  # the reader accepts what simulate wrote
        # nothing else appears beside the inputs and the outputs (no staging left)
        names = {p.name for p in tmp_path.iterdir()}
        assert all(re.fullmatch(r"m\d+\.toml|o\d+(\.h5)?", n) for n in names), names
    print(counts)
    # the mutants reach both outcomes: enough stay valid to test what is written
    assert counts[2] >= N_MUTANTS // 4 and counts[0] >= N_MUTANTS // 20, counts


@pytest.mark.parametrize("value", ["0", "1e-320", "-1"])
def test_a_linear_path_with_no_pulse_spacing_is_refused(tmp_path, capsys, value):
    text = BASE[: BASE.index("[trajectory]")] + LINEAR + BASE[BASE.index("[[targets]]") - 1 :]
    text = text.replace("pulse_spacing_m = 1.0", f"pulse_spacing_m = {value}")
    path = tmp_path / "s.toml"
    path.write_text(text)
    capsys.readouterr()
    assert run(["simulate", str(path), "--out", str(tmp_path / "o.h5")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "pulse_spacing_m" in err
    assert math.isfinite(len(err))
    assert not (tmp_path / "o.h5").exists() and Path(path).exists()
