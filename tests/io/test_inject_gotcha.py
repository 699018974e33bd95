"""Targets injected into real GOTCHA phase history image where they were put."""

import numpy as np
import pytest

from sarmotion.imaging import ImageGrid, backproject
from sarmotion.io import read_gotcha
from sarmotion.simulation import PointTarget, inject


@pytest.mark.gotcha
def test_injected_targets_focus_at_their_true_positions(gotcha_files):
    data = read_gotcha(gotcha_files)  # 4 degrees
    amp = float(np.median(np.abs(data.data).max(axis=1)))
    still = PointTarget(position_m=[8.3, -31.2], reflectivity=amp)
    mover = PointTarget(position_m=[-4.6, 12.7], velocity_mps=[6.0, -3.0], reflectivity=amp)
    injected = inject(data, [still, mover])
    spacing = 0.1
    for tgt in (still, mover):
        grid = ImageGrid.square(centre_m=tgt.position_m[:2], size_m=8.0, spacing_m=spacing)
        img = backproject(injected, grid, velocity_mps=tgt.velocity_mps)
        x, y, _ = img.peak()
        # Within one pixel of the true position at s = 0, in real clutter.
        assert abs(x - tgt.position_m[0]) <= spacing + 1e-9
        assert abs(y - tgt.position_m[1]) <= spacing + 1e-9
        # And it is the target, not clutter: the peak is far above the same image
        # formed without the injection.
        bare = backproject(data, grid, velocity_mps=tgt.velocity_mps)
        assert np.abs(img.values).max() > 3 * np.abs(bare.values).max()
