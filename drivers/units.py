"""Physical constants and unit conversions shared by the drivers, the analysis and the applications."""

from __future__ import annotations

#: Standard acceleration of gravity in m/s² (1 g), by definition (CGPM 1901).
STANDARD_GRAVITY_M_S2 = 9.80665
