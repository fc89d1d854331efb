"""coopproc.distributions gives scipy.stats' numbers to the bit, without its import."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from scipy import stats

from coopproc.distributions import chi2_ppf, t_ppf, t_sf

Q = [0.0, 1e-12, 0.025, 0.05, 0.5, 0.6, 0.95, 0.975, 0.995, 1.0 - 1e-12, 1.0, -0.1, 1.1, np.nan]
DOF = [0.3, 1.0, 1.5, 2.0, 2.75, 7.3, 30.0, 1e3, 1e6, 0.0, -1.0, np.nan, np.inf]


def _same(mine: np.ndarray, theirs: np.ndarray) -> None:
    mine, theirs = np.asarray(mine), np.asarray(theirs)
    assert mine.shape == theirs.shape
    assert np.array_equal(mine, theirs, equal_nan=True), (mine, theirs)


@pytest.mark.parametrize("dof", DOF)
def test_student_quantiles_and_tails_are_scipys(dof: float) -> None:
    q = np.array(Q)
    _same(t_ppf(q, dof), stats.t.ppf(q, dof))
    x = np.array([-np.inf, -3.0, -0.0, 0.0, 1e-300, 0.7, 1.96, 12.0, 1e10, np.inf, np.nan])
    _same(t_sf(x, dof), stats.t.sf(x, dof))
    for value in (0.975, 0.6):  # the scalars bootstrap.py asks for
        assert float(t_ppf(value, dof)) == float(stats.t.ppf(value, dof)) or np.isnan(
            stats.t.ppf(value, dof)
        )


def test_chi_square_quantiles_are_scipys() -> None:
    q = np.array(Q)
    for dof in [*DOF, 3, 10, 50]:
        _same(chi2_ppf(q, dof), stats.chi2.ppf(q, dof))
    dofs = np.arange(1, 400)  # anchor_lsq's vector of degrees of freedom, an int array
    _same(chi2_ppf(0.999, dofs), stats.chi2.ppf(0.999, dofs))
    _same(chi2_ppf([0.025, 0.975], 60), stats.chi2.ppf([0.025, 0.975], 60))


def test_a_run_does_not_import_scipy_stats() -> None:
    """The point of the module: the run's modules leave scipy.stats (~0.8 s) out."""
    code = (
        "import sys\n"
        "import coopproc.cli.run, coopproc.run.pipeline, coopproc.run.output\n"
        "import coopproc.report.figures, coopproc.report.html\n"
        "print('scipy.stats' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "False"
