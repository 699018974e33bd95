"""Physical constants (SI units, float64)."""

#: Speed of light in vacuum (m/s).
C: float = 299_792_458.0
