"""The identified film in control design: rational (state-space) approximations with a stated error, their exports,
and a time-domain check against the recorded hits.

* :mod:`.fitting` — weighted vector fitting and Oustaloup's approximation of ``s^α``;
* :mod:`.rational` — :func:`~.rational.approximate` (order search, stability, passivity), :class:`~.rational.PlantSource`;
* :mod:`.export` — ``.json`` / ``.mat`` / ``.npz`` files a control engineer loads without gasfilm;
* :mod:`.timedomain` — the fractional and rational models driven by each recorded hit's force.
"""

from gasfilm.analysis.control.rational import DEFAULT_MAX_ERROR, PlantSource, RationalModel, approximate

__all__ = ["DEFAULT_MAX_ERROR", "PlantSource", "RationalModel", "approximate"]
