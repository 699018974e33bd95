"""Regenerate the built-in scene files in src/sarmotion/scenes (run once; output is committed).

Where the paper does not list stationary positions, they are drawn uniformly in the
50 m x 50 m region centred on the origin with a fixed seed, recorded in each file.
"""

from pathlib import Path

import numpy as np

OUT = Path(__file__).resolve().parents[1] / "src" / "sarmotion" / "scenes"
S2 = np.sqrt(2.0)
S3 = np.sqrt(3.0)
MOVER_28 = ([0.0, 0.0], [28 / S2, 28 / S2])
MOVER_14 = ([-5.0, 5.0], [-14 / S3, 14 * S2 / S3])

HEADER = 'schema = "sarmotion.scene/1"\n'


def fmt(v):
    return "[" + ", ".join(f"{x:.6f}" for x in v) + "]"


def write(name, description, stationary, movers, trajectory=None, extra=""):
    lines = [
        HEADER,
        f'name = "{name}"\n',
        f'description = """{description}"""\n',
        "reference_point_m = [0.0, 0.0]\n",
    ]
    # The paper's compressed pulse cos(w t) exp(-B^2 t^2 / 2) (eq:compPulse).
    lines.append('\n[radar]\npulse = "gaussian"\n')
    if trajectory:
        lines.append("\n[trajectory]\n")
        for k, v in trajectory.items():
            lines.append(
                f"{k} = {fmt(v) if isinstance(v, list) else repr(v).replace(chr(39), chr(34))}\n"
            )
    for p in stationary:
        lines.append(f"\n[[targets]]\nposition_m = {fmt(p)}\n")
    for k, (p, v) in enumerate(movers):
        lines.append(
            f'\n[[targets]]\nlabel = "mover {k + 1}"\nposition_m = {fmt(p)}\n'
            f"velocity_mps = {fmt(v)}\n"
        )
    (OUT / f"{name}.toml").write_text("".join(lines) + extra)


def draw(n, seed):
    return np.random.default_rng(seed).uniform(-25.0, 25.0, size=(n, 2))


GOTCHA_1DEG = {"kind": "circular", "aperture_deg": 1.0}

write(
    "example1",
    "Example 1 of sect:RPCA: seven stationary targets at (0,0), (+-5,0), "
    "(0,+-5), (+-10,0) m and one mover at (0,0) m with velocity 28/sqrt(2) (1,1) m/s. "
    "GOTCHA geometry, 1 degree aperture.",
    [[0, 0], [5, 0], [-5, 0], [0, 5], [0, -5], [10, 0], [-10, 0]],
    [MOVER_28],
    GOTCHA_1DEG,
)
write(
    "example2",
    "Example 2 of sect:RPCA: thirty stationary targets drawn uniformly in "
    "[-25, 25]^2 m (seed 2), and the mover of Example 1. GOTCHA geometry, 1 degree.",
    draw(30, 2),
    [MOVER_28],
    GOTCHA_1DEG,
)
write(
    "scene1",
    "Scene 1 (sect:algdesc, sect:numeric): twenty stationary targets drawn "
    "uniformly in [-25, 25]^2 m (seed 1), a mover at (0,0) m with 28/sqrt(2) (1,1) m/s "
    "and a mover at (-5,5) m with 14/sqrt(3) (-1, sqrt 2) m/s. GOTCHA geometry, 1 degree.",
    draw(20, 1),
    [MOVER_28, MOVER_14],
    GOTCHA_1DEG,
)
write(
    "filter10",
    "Annihilation example (fig:filter10scatt1ord): ten stationary targets "
    "drawn uniformly in [-25, 25]^2 m (seed 10) and a mover at (0,0) m with "
    "28/sqrt(2) (1,1) m/s. GOTCHA geometry, 1 degree.",
    draw(10, 10),
    [MOVER_28],
    GOTCHA_1DEG,
)
write(
    "filter30",
    "Annihilation example (fig:filter30scatt1ord): thirty stationary targets "
    "drawn uniformly in [-25, 25]^2 m (seed 30) and a mover at (0,0) m with "
    "28/sqrt(2) (1,1) m/s. GOTCHA geometry, 1 degree.",
    draw(30, 30),
    [MOVER_28],
    GOTCHA_1DEG,
)
L = 10_000.0
ground = 7000.0
write(
    "hyperbola",
    "fig:hyperbola: one stationary target at (0,5,0) m seen from a linear "
    "400 m aperture flown at 70 m/s, 10 km from the target (ground offset 7 km).",
    [[0, 5]],
    [],
    {
        "kind": "linear",
        "centre_m": [ground, 0.0, float(np.sqrt(L**2 - ground**2))],
        "direction": [0.0, 1.0, 0.0],
        "speed_mps": 70.0,
        "aperture_m": 400.0,
        "pulse_spacing_m": 1.055,
    },
)
write(
    "rotscatt",
    "fig:rotScatt: one stationary target at (-5,10) m and a mover at (0,0) m "
    "with 28/sqrt(2) (1,1) m/s (28 m/s). GOTCHA geometry, 1 degree.",
    [[-5, 10]],
    [MOVER_28],
    GOTCHA_1DEG,
)
