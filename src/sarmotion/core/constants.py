"""Physical constants (SI units, float64)."""

#: Speed of light in vacuum (m/s).
C: float = 299_792_458.0

# ----------------------------------------------------------- plausible acquisitions
# The bounds every input must meet, stated once: the readers' plausibility rules
# (:mod:`sarmotion.io.plausibility`) and the scene files (:mod:`sarmotion.simulation.scene`)
# use these values.

#: Antenna distance from the scene centre (m) inside which positions are plausible.
RANGE_ENVELOPE_M: tuple[float, float] = (10.0, 1e6)
#: Platform speeds (m/s) implied by positions and slow times: from a ground-based rail
#: SAR (mm/s) to a satellite in low orbit (7.6 km/s), as ``--speed`` accepts.
SPEED_RANGE_MPS: tuple[float, float] = (1e-3, 1e4)
#: Smallest grazing angle (deg) at which the antenna sees the reference point. Airborne
#: SAR images at about 10-60 deg, spaceborne at 15-75 deg; below a few degrees the
#: ground is in shadow and multipath. 5 deg is half the usual airborne minimum; a
#: reference point displaced by 100 km from a scene seen from 7 km altitude is at 4 deg.
MIN_GRAZING_DEG: float = 5.0
#: Radar carrier frequencies (Hz): the radio spectrum from HF (3 MHz; no imaging radar
#: works below it, VHF foliage-penetrating SAR starts at 20 MHz) to its upper edge,
#: 3 THz (terahertz imaging radars reach 0.3-0.7 THz).
CARRIER_RANGE_HZ: tuple[float, float] = (3e6, 3e12)
