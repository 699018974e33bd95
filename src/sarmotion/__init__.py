"""sarmotion: single-antenna SAR imaging and motion estimation of complex scenes.

Implements Borcea, Callaghan & Papanicolaou, "Motion Estimation and Imaging of
Complex Scenes with Synthetic Aperture Radar": separation of the echoes of
stationary and moving targets (travel-time annihilation filters, windowed robust
PCA and their combination), range and cross-range speed estimation, separation of
movers, trajectory estimation and focused imaging.
"""

__version__ = "0.1.0"
