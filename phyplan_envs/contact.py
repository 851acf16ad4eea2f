"""MuJoCo contact parameters and the restitution they give (negative ``solref``: stiffness and damping).

A contact with ``solref = (-K, -D)`` behaves like a damped spring; a ball bouncing on it keeps the fraction ``e``
of its normal speed with ``D = 2 zeta sqrt(K)`` and ``zeta = -ln e / sqrt(pi^2 + ln^2 e)``. The Bounce task's
incline (``assets.ELASTIC_SOLREF``) and the bounce skill scene (which varies ``e``) both use these relations.
"""
from __future__ import annotations

import math

DEFAULT_STIFFNESS = 200000.0   # the K of assets.ELASTIC_SOLREF (docs/physics.md: the good default at dt 0.001)


def solref_for_restitution(e: float, stiffness: float = DEFAULT_STIFFNESS) -> tuple[float, float]:
    """MuJoCo's negative ``solref`` (-K, -D) for a contact of restitution ``e``.

    ``D = 2 zeta sqrt(K)`` with ``zeta = -ln e / sqrt(pi^2 + ln^2 e)`` (a damped spring's bounce); e in (0, 1].
    ``assets.ELASTIC_SOLREF`` (-200000 -15) is e = 0.95 by this rule.
    """
    e = float(e)
    if not 0.0 < e <= 1.0:
        raise ValueError(f"restitution must be in (0, 1], got {e}")
    le = math.log(e)
    zeta = -le / math.sqrt(math.pi ** 2 + le * le)
    return (-float(stiffness), -2.0 * zeta * math.sqrt(stiffness))


def restitution_of_solref(solref) -> float:
    """The nominal restitution of a negative ``solref`` ("-K -D" string or a pair): the inverse of
    :func:`solref_for_restitution`. ``restitution_of_solref(assets.ELASTIC_SOLREF)`` is ~0.95."""
    if isinstance(solref, str):
        solref = [float(v) for v in solref.split()]
    k, dmp = -float(solref[0]), -float(solref[1])
    if k <= 0 or dmp < 0:
        raise ValueError(f"expected a negative solref (-K, -D) with K > 0, D >= 0; got {solref!r}")
    zeta = dmp / (2.0 * math.sqrt(k))
    if zeta >= 1.0:
        return 0.0
    return math.exp(-math.pi * zeta / math.sqrt(1.0 - zeta * zeta))
