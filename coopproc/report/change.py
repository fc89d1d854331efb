"""The change of a method's statistic against Observed, as the report's tables show it.

One rule for every format (terminal, CSV, Markdown, LaTeX, HTML):

- **relative, in %**: ``100 (v - o) / |o|`` (v the method's value, o the ``observed``
  value of the same pair / platform) for *magnitudes*: non-negative statistics such as
  Max, RMSE, the mean of horizontal errors, CEP, RMS, Std, smoothness;
- **absolute, ``v - o`` in the column's unit** (e.g. ``+0.0012 m``):

  - for *signed* statistics (the mean of signed distance errors of Table 2, biases): a
    percentage of a mean near zero says nothing ("+8205.1 %"), and a sign change is not
    a percentage;
  - for statistics in dB (SNR): a dB difference already is a ratio;
  - for statistics in % (relative errors): the change in percentage points (``pp``);
  - whenever the reference is near zero: ``|o|`` below ten units of the column's last
    printed digit (0.0010 m at four decimals), where a percentage mostly shows rounding.

Statistics that are not compared (``n``, counts, ``better`` None) have no change.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["RELATIVE", "Change", "change_of", "signed_text"]

#: The unit of a relative change.
RELATIVE = "%"


def signed_text(value: float, decimals: int) -> str:
    """``value`` with its sign (``+0.0012``, ``-50.2``); zero at this precision unsigned."""
    text = f"{value:+.{decimals}f}"
    return text[1:] if float(text) == 0.0 else text


@dataclass(frozen=True)
class Change:
    """A change against Observed: ``value`` in ``unit`` (``%``: relative) shown with
    ``decimals`` decimals; ``unit`` "" is an absolute change of a dimensionless statistic."""

    value: float
    unit: str
    decimals: int

    @property
    def relative(self) -> bool:
        """True for a relative change in %."""
        return self.unit == RELATIVE

    @property
    def number(self) -> str:
        """The signed number alone, e.g. ``-50.2`` or ``+0.0012``."""
        return signed_text(self.value, self.decimals)

    def text(self) -> str:
        """``-50.2%``, ``+0.0012 m``, ``+5.29 dB``, ``+0.12 pp``, ``+0.0012``."""
        if self.relative:
            return f"{self.number}%"
        return f"{self.number} {self.unit}" if self.unit else self.number


def change_of(
    value: float, observed: float, *, unit: str, decimals: int, signed: bool
) -> Change | None:
    """The change of ``value`` against ``observed`` by the module's rule (None if either is
    not finite). ``unit`` / ``decimals``: the column's; ``signed``: the statistic can be
    negative (a mean of signed errors, a bias)."""
    if not (math.isfinite(value) and math.isfinite(observed)):
        return None
    diff = value - observed
    if unit == "dB":
        return Change(diff, "dB", decimals)
    if unit == "%":
        return Change(diff, "pp", decimals)
    if signed or abs(observed) < 10.0 * 10.0**-decimals:
        return Change(diff, unit, decimals)
    return Change(100.0 * diff / abs(observed), RELATIVE, 1)
