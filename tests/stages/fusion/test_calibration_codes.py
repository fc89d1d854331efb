"""The self-calibration's integer pair / platform codes (issue 11): the same groups, in the
same order, as the pair names they replace."""

from __future__ import annotations

import numpy as np
import pandas as pd

from coopproc.stages.fusion.calibration_bias import (
    code_groups,
    pair_codes,
    platform_rows,
    postfit_residuals,
    residuals_by_row,
)
from coopproc.stages.fusion.fuse import FusionParams, fuse
from coopproc.stages.shared.data import pair_names
from tests.stages.fusion.test_fusion import make_session


def test_pair_codes_name_each_row_as_pair_names_do() -> None:
    # both orientations of a pair, an id with "," (sorts before "-": name order is not
    # the order of the id tuples), a missing id, text columns
    first = pd.Series(["b", "a", "a,", "z", "a", None, "b"], dtype="str")
    second = pd.Series(["a", "b", "z", "a", "z", "a", "c"], dtype="str")
    codes = pair_codes(first, second)
    names = pair_names(first, second)
    assert list(codes.names) == sorted(set(names))
    assert [codes.names[c] for c in codes.code] == list(names)
    assert codes.code.dtype == np.int16
    assert codes.names.index("a,-z") < codes.names.index("a-z")


def test_code_groups_rows_ascending_codes_in_order() -> None:
    code = np.array([2, 0, 2, 2, 0, 3], dtype=np.int16)
    groups = code_groups(code, 5)  # code 1 and 4 occur nowhere: no group
    assert [c for c, _ in groups] == [0, 2, 3]
    assert [rows.tolist() for _, rows in groups] == [[1, 4], [0, 2, 3], [5]]


def test_platform_rows_either_end() -> None:
    frame = pd.DataFrame({"from": ["A", "B", "C", None], "to": ["B", "C", "A", "B"]})
    assert platform_rows(frame, "A").tolist() == [True, False, True, False]
    assert platform_rows(frame, "B").tolist() == [True, True, False, True]
    assert not platform_rows(frame, "Q").any()


def test_residuals_by_row_line_up_with_the_range_rows() -> None:
    session, _, _ = make_session(duration_s=60.0)
    frame = session.ranges.frame[["time", "from", "to", "range", "sigma"]].copy()
    fused = fuse(session, frame, FusionParams(), smoothed_sigma=False)
    frame.loc[frame.index[[3, 10]], "range"] = np.nan  # dropouts: NaN, rows kept
    resid = residuals_by_row(session, fused, frame)
    assert resid.shape[0] == len(frame)
    assert np.isnan(resid[[3, 10]]).all() and np.isfinite(np.delete(resid, [3, 10])).all()
    table = postfit_residuals(session, fused, frame)  # the rows with a range
    assert np.array_equal(table["residual"].to_numpy(), np.delete(resid, [3, 10]))
    assert list(table["pair"].astype(str)) == list(
        pair_names(frame["from"], frame["to"])[np.isfinite(frame["range"].to_numpy())]
    )
    # a residual is the range less the fused distance: lengthen one range, and only its
    # residual grows, by as much
    longer = frame.assign(
        range=frame["range"].to_numpy() + np.where(np.arange(len(frame)) == 5, 1.0, 0.0)
    )
    moved = residuals_by_row(session, fused, longer)
    assert abs(moved[5] - resid[5] - 1.0) < 1e-9
    assert np.array_equal(np.delete(moved, [3, 5, 10]), np.delete(resid, [3, 5, 10]))
