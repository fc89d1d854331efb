"""`coopproc inject`: the new session's files, the draws, the options and their errors."""

from __future__ import annotations

import gzip
import hashlib
from decimal import Decimal
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner, Result

from coopproc.cli import main
from coopproc.errors import ConfigError, InputError
from coopproc.io import read_session
from coopproc.io.injected import INJECTED_COLUMNS, read_injected
from coopproc.sim import simulate, write_simulation
from coopproc.sim.inject import inject_session
from coopproc.sim.inject_plan import GrossInjection, Injection, NlosInjection, OutageInjection

T0 = 108000.0  # the simulator's first epoch (GPS seconds of week)


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """60 s of paper 000's three platforms (pairs A-B, A-C, B-C), ranging at 10 Hz without
    NLOS or dropouts, with its truth/."""
    root = tmp_path_factory.mktemp("inject") / "s"
    sim = simulate(
        "paper-experiment",
        seed=3,
        duration_s=60.0,
        nlos_events=[],
        range_rate_hz=10.0,
        dropout_rate=0.0,
    )
    write_simulation(sim, root)
    return root


def _files(root: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()
    }


def _invoke(*args: str) -> Result:
    return CliRunner().invoke(main, ["inject", *args])


def _one_error(res: Result) -> str:
    """The exit status is 1 and the output is exactly one ``error:`` line."""
    assert res.exit_code == 1, res.output
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), res.output
    assert "Traceback" not in res.output
    return lines[0]


def _ranges(root: Path) -> pd.DataFrame:
    return pd.read_csv(root / "ranges.csv", dtype={"from": str, "to": str})


def test_new_session_is_the_old_one_plus_what_injected_csv_lists(
    session: Path, tmp_path: Path
) -> None:
    before = _files(session)
    res = _invoke(
        str(session), "-o", str(tmp_path / "new"),
        "--nlos", "A-B", "+10", "+20", "0.5", "0.1",
        "--gross", "B-A", "+30", "2.0",
        "--outage", "+40", "+45", "--pairs", "A-C",
        "--nlos", "B-C", "+45", "+55", "1.0", "0.05",
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    assert "2 NLOS events" in res.output and "1 outage" in res.output
    assert _files(session) == before  # the input is never modified
    new = tmp_path / "new"
    after = _files(new)
    assert set(after) == {*before, "injected.csv"}
    changed = {"ranges.csv", "truth/distances.csv", "truth/nlos_events.csv"}
    changed |= {"truth/gross_errors.csv"}
    for name, data in before.items():
        if name not in changed:
            assert after[name] == data, name  # session.toml, nav, ref, truth trajectories...
    injected = read_injected(new / "injected.csv")
    assert tuple(injected.columns) == INJECTED_COLUMNS
    old, out = _ranges(session), _ranges(new)
    old_pair = np.where(
        old["from"] < old["to"], old["from"] + "-" + old["to"], old["to"] + "-" + old["from"]
    )
    removed = (old_pair == "A-C") & (old["time"] >= T0 + 40) & (old["time"] <= T0 + 45)
    outage = injected[injected["kind"] == "outage"]
    assert len(outage) == removed.sum() > 0 and outage["error"].isna().all()
    kept = old[~removed].reset_index(drop=True)
    assert len(out) == len(kept)
    # every other column as it was; range = old range + the recorded errors, exactly
    pd.testing.assert_frame_equal(out.drop(columns="range"), kept.drop(columns="range"))
    added = injected[injected["kind"] != "outage"].groupby(["time", "pair"])["error"].sum()
    diff = out["range"] - kept["range"]
    touched = diff.abs() > 0
    assert touched.sum() == len(injected[injected["kind"] != "outage"])
    key = list(zip(kept["time"][touched], old_pair[~removed][touched], strict=True))
    np.testing.assert_allclose(diff[touched], added.loc[key].to_numpy(), atol=1e-9)
    nlos1 = injected[injected["event"] == "nlos1"]
    assert (nlos1["pair"] == "A-B").all() and nlos1["time"].between(T0 + 10, T0 + 20).all()
    in_window = (old_pair == "A-B") & old["time"].between(T0 + 10, T0 + 20)
    assert len(nlos1) == in_window.sum()  # one draw per range, not one per event
    assert nlos1["error"].nunique() == len(nlos1)
    gross = injected[injected["kind"] == "gross"]
    ab_times = old["time"][old_pair == "A-B"]
    nearest = ab_times[(ab_times - (T0 + 30)).abs() == (ab_times - (T0 + 30)).abs().min()]
    assert sorted(gross["time"]) == sorted(nearest) and (gross["error"] == 2.0).all()
    read_session(new)  # a valid session


def test_truth_of_a_simulated_session_follows_the_injection(session: Path, tmp_path: Path) -> None:
    out = tmp_path / "new"
    injection = Injection(
        nlos=(NlosInjection("A-B", "+10", "+20", 0.5, 0.1),),
        gross=(GrossInjection("A-C", "+30", -1.5),),
        outages=(OutageInjection("+40", "+42"),),
        seed=4,
    )
    result = inject_session(session, out, injection)
    assert any("truth/distances.csv" in n for n in result.notes)
    ranges, truth = _ranges(out), pd.read_csv(out / "truth" / "distances.csv")
    assert len(ranges) == len(truth)
    np.testing.assert_allclose(ranges["range"] - truth["distance"], truth["error"], atol=2e-6)
    events = pd.read_csv(out / "truth" / "nlos_events.csv")
    row = events.iloc[-1]
    nlos = result.records[result.records["kind"] == "nlos"]
    assert (row["pair"], row["epochs"], row["nominal_mean"]) == ("A-B", len(nlos), 0.5)
    assert row["realized_mean"] == pytest.approx(nlos["error"].mean(), abs=1e-6)
    gross = pd.read_csv(out / "truth" / "gross_errors.csv")
    assert (gross["pair"] == "A-C").all() and (gross["error"] == -1.5).all() and len(gross)


def test_same_seed_same_bytes_other_seed_other_draws(session: Path, tmp_path: Path) -> None:
    args = ["--nlos", "A-B", "+5", "+25", "0.8", "0.2", "--outage", "+50", "+52"]
    for name, seed in (("one", "7"), ("two", "7"), ("three", "8")):
        res = _invoke(str(session), "-o", str(tmp_path / name), *args, "--seed", seed)
        assert res.exit_code == 0, res.output
    one, two, three = (_files(tmp_path / n) for n in ("one", "two", "three"))
    assert one == two
    assert one["ranges.csv"] != three["ranges.csv"]
    draws = read_injected(tmp_path / "one" / "injected.csv")
    draws = draws[draws["kind"] == "nlos"]["error"]
    assert len(draws) > 150  # 20 s at 10 Hz
    assert draws.mean() == pytest.approx(0.8, abs=4 * 0.2 / np.sqrt(len(draws)))
    assert draws.std() == pytest.approx(0.2, rel=0.2)


def test_relative_and_absolute_times_and_pair_order_agree(session: Path, tmp_path: Path) -> None:
    for name, pair, start, end in (
        ("rel", "A-B", "+10", "+12"),
        ("abs", "B-A", f"{T0 + 10}", f"{T0 + 12}"),
    ):
        res = _invoke(
            str(session), "-o", str(tmp_path / name), "--nlos", pair, start, end, "1", "0"
        )
        assert res.exit_code == 0, res.output
    assert _files(tmp_path / "rel")["ranges.csv"] == _files(tmp_path / "abs")["ranges.csv"]
    injected = read_injected(tmp_path / "rel" / "injected.csv")
    assert (injected["error"] == 1.0).all() and (injected["pair"] == "A-B").all()


def test_file_form_is_kept_comments_crlf_quotes_gzip(session: Path, tmp_path: Path) -> None:
    lines = (session / "ranges.csv").read_text().splitlines()
    body = [lines[0], *(f'"{ln}"'.replace(",", '","') if i % 7 == 0 else ln
                        for i, ln in enumerate(lines[1:]))]  # fmt: skip
    text = "# made by hand\r\n\r\n" + "\r\n".join(body) + "\r\n"
    for name in ("plain", "gz"):
        src = tmp_path / f"{name}-src"
        src.mkdir()
        for path in session.iterdir():
            if path.is_file() and path.name != "ranges.csv":
                (src / path.name).write_bytes(path.read_bytes())
        target = src / ("ranges.csv.gz" if name == "gz" else "ranges.csv")
        data = text.encode()
        target.write_bytes(gzip.compress(data, mtime=0) if name == "gz" else data)
        out = tmp_path / f"{name}-out"
        res = _invoke(str(src), "-o", str(out), "--nlos", "A-B", "+10", "+11", "0.5", "0.1")
        assert res.exit_code == 0, res.output
        new = (out / target.name).read_bytes()
        new_text = (gzip.decompress(new) if name == "gz" else new).decode()
        old_lines, new_lines = text.split("\r\n"), new_text.split("\r\n")
        assert len(old_lines) == len(new_lines) and new_lines[0] == "# made by hand"
        changed = [(a, b) for a, b in zip(old_lines, new_lines, strict=True) if a != b]
        injected = read_injected(out / "injected.csv")
        assert len(changed) == len(injected) > 0
        for (a, b), error in zip(changed, injected["error"], strict=True):
            fa, fb = a.replace('"', "").split(","), b.replace('"', "").split(",")
            assert fa[:3] == fb[:3] and fa[4:] == fb[4:]
            assert Decimal(fb[3]) - Decimal(fa[3]) == Decimal(f"{error:.6f}")


def _error(session: Path, out: Path, *args: str) -> str:
    return _one_error(_invoke(str(session), "-o", str(out), *args))


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (("--nlos", "AB", "+1", "+2", "0.5", "0.1"), "did you mean 'A-B'?"),
        (("--gross", "B-X", "+1", "2"), "no ranges of pair 'B-X'"),
        (("--nlos", "A-B", "+50", "+70", "0.5", "0.1"), "window reaches outside the session"),
        (("--outage", "+100", "+110"), "window outside the session"),
        (("--outage", "-20", "-10"), "window outside the session"),
        (("--nlos", "A-B", "+5", "+4", "0.5", "0.1"), "END must be after START"),
        (("--nlos", "A-B", "+5", "+6", "-0.5", "0.1"), "MEAN -0.5; expected metres > 0"),
        (("--nlos", "A-B", "+5", "+6", "0.5", "-1"), "SD -1; expected metres >= 0"),
        (("--nlos", "A-B", "+5", "five", "0.5", "0.1"), "time 'five' is not a number"),
        (("--gross", "A-B", "+5", "0"), "SIZE 0; expected metres, not 0"),
        (("--gross", "A-B", "+5", "-30"), "would be negative"),
        (("--outage", "+1", "+2", "--pairs", "A-B,C-Q"), "no ranges of pair 'C-Q'"),
        (
            ("--nlos", "A-B", "+5", "+8", "0.5", "0.1", "--nlos", "B-A", "+7", "+9", "0.5", "0.1"),
            "overlaps an earlier --nlos window on A-B",
        ),
        (
            ("--gross", "A-B", "+20", "2", "--outage", "+19", "+21", "--pairs", "A-B"),
            "is removed by --outage",
        ),
        (
            ("--nlos", "A-B", "+20", "+21", "0.5", "0.1", "--outage", "+19", "+22"),
            "every range in the window is removed",
        ),
        ((), "nothing to inject"),
    ],
)
def test_bad_options_are_one_line(
    session: Path, tmp_path: Path, args: tuple[str, ...], words: str
) -> None:
    line = _error(session, tmp_path / "new", *args)
    assert words in line
    assert not (tmp_path / "new").exists()


def test_pairs_without_outage_is_a_usage_error(session: Path, tmp_path: Path) -> None:
    res = _invoke(str(session), "-o", str(tmp_path / "n"), "--pairs", "A-B")
    assert res.exit_code == 2 and "--pairs must follow an --outage" in res.output


def test_outputs_are_checked_and_replaced_only_with_force(session: Path, tmp_path: Path) -> None:
    args = ("--gross", "A-B", "+5", "1.0")
    out = tmp_path / "new"
    assert _invoke(str(session), "-o", str(out), *args).exit_code == 0
    assert "use --force" in _error(session, out, *args)
    res = _invoke(str(session), "-o", str(out), *args, "--gross", "A-C", "+6", "1", "--force")
    assert res.exit_code == 0, res.output
    assert "inside the session" in _error(session, session / "sub", *args)
    assert "over the input session" in _error(session, session, *args, "--force")
    assert "made by coopproc inject" in _error(out, tmp_path / "again", *args)


def test_mcap_sessions_are_refused_in_one_line(tmp_path: Path) -> None:
    sim = simulate("paper-table1", seed=0, duration_s=20.0)
    write_simulation(sim, tmp_path / "s", mcap=True)
    mcap = tmp_path / "s" / "mcap" / "paper-table1.mcap"
    assert "does not support MCAP" in _error(mcap, tmp_path / "n", "--gross", "A-B", "+5", "1")
    only = tmp_path / "only"
    only.mkdir()
    only.joinpath("run.mcap").write_bytes(mcap.read_bytes())
    assert "does not support MCAP ranges" in _error(
        only, tmp_path / "m", "--gross", "A-B", "+5", "1"
    )


def test_library_errors_name_the_option(session: Path, tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"^--nlos A-Q \+1 \+2 0.5 0.1: no ranges of pair"):
        inject_session(
            session, tmp_path / "n", Injection(nlos=(NlosInjection("A-Q", "+1", "+2", 0.5, 0.1),))
        )
    with pytest.raises(InputError, match="no such session directory"):
        inject_session(
            tmp_path / "missing",
            tmp_path / "n",
            Injection(gross=(GrossInjection("A-B", 1.0, 1.0),)),
        )


_HEADER = "time,pair,kind,error,event,start,end,mean,sd\n"


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("time,pair,kind,error,event\n", "missing columns"),
        (_HEADER + "1,A-B,nlos,x,nlos1,0,2,0.5,0.1\n", "'x' is not a number"),
        (_HEADER + "1,A-B,blip,0.1,b1,0,2,,\n", "kind 'blip'"),
        (_HEADER + "1,A-B,gross,,g1,1,1,2,\n", "gross row without an error"),
        (_HEADER + ",A-B,nlos,0.5,nlos1,0,2,0.5,0.1\n", "column 'time': empty"),
    ],
)
def test_injected_csv_reader_errors(tmp_path: Path, text: str, words: str) -> None:
    path = tmp_path / "injected.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=words) as err:
        read_injected(path)
    assert "\n" not in str(err.value)


def test_sha_of_the_input_is_unchanged_by_a_failed_call(session: Path, tmp_path: Path) -> None:
    digest = hashlib.sha256((session / "ranges.csv").read_bytes()).hexdigest()
    _error(session, tmp_path / "n", "--gross", "A-B", "+500", "1")
    assert hashlib.sha256((session / "ranges.csv").read_bytes()).hexdigest() == digest
