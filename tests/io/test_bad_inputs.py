"""One test per bad input of issue 2: a one-line message naming file, line, found, expected."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from coopproc.cli import main
from coopproc.errors import ConfigError, CoopprocError, InputError
from coopproc.io import read_session, validate_session, write_mcap


def _edit(path: Path, old: str, new: str) -> None:
    text = path.read_text()
    assert old in text, old
    path.write_text(text.replace(old, new, 1))


def _line(path: Path, number: int, new: str) -> None:
    lines = path.read_text().splitlines()
    lines[number - 1] = new
    path.write_text("\n".join(lines) + "\n")


def _problems(path: Path) -> list[str]:
    problems = validate_session(path)
    assert problems, "expected problems"
    for p in problems:
        assert "\n" not in p
    with pytest.raises(CoopprocError) as info:
        read_session(path)
    assert str(info.value) == problems[0] or str(info.value).startswith(problems[0][:40])
    return problems


def test_clean_session_has_no_problems(sample_dir: Path) -> None:
    assert validate_session(sample_dir) == []


def test_malformed_row(sample_dir: Path) -> None:
    _line(sample_dir / "nav_A.csv", 4, "432000.2,1.0,2.0,3.0,0.05,0.05,0.05,0.5,0,0,90,99,98")
    (msg,) = _problems(sample_dir)
    assert msg.endswith("nav_A.csv:4: malformed row: 13 fields, expected 11 (the header's columns)")


def test_missing_column(sample_dir: Path) -> None:
    path = sample_dir / "ranges.csv"
    pd.read_csv(path).drop(columns=["range"]).to_csv(path, index=False)
    (msg,) = _problems(sample_dir)
    assert msg == f"{path}: missing column 'range'; found columns time, from, to, sigma, rssi"
    problems = validate_session(sample_dir)
    assert any(
        "ranges.csv: missing column 'range'; found columns time, from, to" in p for p in problems
    )


def test_misspelled_columns(sample_dir: Path) -> None:
    _edit(sample_dir / "ranges.csv", "time,from,to,range,", "time,from,to,ragne,")
    _edit(sample_dir / "nav_B.csv", "time,east,north,", "time,east,nroth,")
    problems = _problems(sample_dir)
    assert any(
        p.endswith("nav_B.csv: unknown column 'nroth' (did you mean 'north'?)") for p in problems
    )
    assert any(
        "ranges.csv: missing column 'range'; found 'ragne' (misspelled?)" in p for p in problems
    )


@pytest.mark.parametrize(("value", "found"), [("nan", "empty or NaN"), ("inf", "found inf")])
def test_nan_and_inf(sample_dir: Path, value: str, found: str) -> None:
    path = sample_dir / "ranges.csv"
    _line(path, 3, f"432000.000000,B,C,{value},,-79.5")
    (msg,) = _problems(sample_dir)
    assert msg.startswith(f"{path}:3: column 'range': {found}")


def test_non_number(sample_dir: Path) -> None:
    _line(sample_dir / "nav_C.csv", 5, "432000.3,abc,1,1,0.05,0.05,0.05,0.5,0,0,92")
    (msg,) = _problems(sample_dir)
    assert msg.endswith("nav_C.csv:5: column 'east': found 'abc', expected a number")


def test_negative_and_absurd_ranges(sample_dir: Path) -> None:
    path = sample_dir / "ranges.csv"
    _line(path, 2, "432000.000000,A,B,-3.2,,-80.0")
    _line(path, 6, "432001.000000,B,A,12000.0,0.1,-78.0")
    problems = _problems(sample_dir)
    assert f"{path}:2: range -3.2 m is negative; expected 0..2000 m" in problems
    assert f"{path}:6: range 12000.0 m is absurd for UWB; expected 0..2000 m" in problems


def test_conflicting_duplicated_times(sample_dir: Path) -> None:
    path = sample_dir / "nav_A.csv"
    lines = path.read_text().splitlines()
    lines[3] = lines[2].replace(",0.", ",9.", 1)  # same time as line 3, other position
    path.write_text("\n".join(lines) + "\n")
    (msg,) = _problems(sample_dir)
    assert msg.startswith(f"{path}:4: time 432000.1 appears twice with different positions")
    assert msg.endswith("expected strictly increasing times")


def test_range_to_platform_without_navigation(sample_dir: Path) -> None:
    (sample_dir / "nav_C.csv").unlink()
    (sample_dir / "ref_C.pos").unlink()
    problems = _problems(sample_dir)
    assert any(
        ":3: platform 'C' has no navigation (nav_C.csv) and is not an anchor; "
        "expected one of A, B, X (and 14 more rows)" in p
        for p in problems
    )


def test_platform_ranging_to_itself(sample_dir: Path) -> None:
    _line(sample_dir / "ranges.csv", 2, "432000.000000,A,A,5.0,,-80.0")
    (msg,) = _problems(sample_dir)
    assert msg.endswith(
        "ranges.csv:2: platform A ranges to itself; expected two different platforms"
    )


def test_time_spans_do_not_overlap(sample_dir: Path) -> None:
    path = sample_dir / "nav_B.csv"
    path.write_text(path.read_text().replace("\n4320", "\n4330"))
    problems = _problems(sample_dir)
    assert any(
        "nav_B.csv: time span 433000.000..433004.900 does not overlap the ranges' "
        "432000.000..432004.000" in p
        for p in problems
    )
    assert any(
        "ref_B.pos: time span 432000.000..432004.900 does not overlap the navigation" in p
        for p in problems
    )


@pytest.mark.parametrize("name", ["nav_A.csv", "ranges.csv", "ref_A.pos", "session.toml"])
def test_empty_files(sample_dir: Path, name: str) -> None:
    (sample_dir / name).write_text("" if name != "session.toml" else "[time]\nbase = \n")
    problems = _problems(sample_dir)
    expected = {
        "nav_A.csv": "nav_A.csv: empty file; expected a header line and data rows",
        "ranges.csv": "ranges.csv: empty file; expected a header line and data rows",
        "ref_A.pos": "ref_A.pos: no RTKLIB column header; expected a line like",
        "session.toml": "session.toml: not valid TOML: Invalid value (at line 2, column 8)",
    }[name]
    assert any(expected in p for p in problems), problems


def test_header_only_nav(sample_dir: Path) -> None:
    path = sample_dir / "nav_A.csv"
    path.write_text(path.read_text().splitlines()[0] + "\n")
    (msg,) = _problems(sample_dir)
    assert msg.endswith("nav_A.csv: no data rows; expected at least one epoch")


def test_truncated_mcap(tmp_path: Path, kit: object) -> None:
    path = write_mcap(kit.make_session(), tmp_path / "s.mcap")  # type: ignore[attr-defined]
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    (msg,) = _problems(path)
    assert msg.startswith(f"{path}: ") and "MCAP" in msg
    assert "truncated MCAP: no footer" in msg or "runs past the end" in msg


def test_corrupt_mcap(tmp_path: Path, kit: object) -> None:
    path = write_mcap(kit.make_session(), tmp_path / "s.mcap")  # type: ignore[attr-defined]
    data = bytearray(path.read_bytes())
    middle = len(data) // 2
    data[middle : middle + 64] = bytes(64)
    path.write_bytes(bytes(data))
    (msg,) = _problems(path)
    assert msg.startswith(f"{path}: corrupt MCAP")
    (tmp_path / "e.mcap").write_bytes(b"")
    assert validate_session(tmp_path / "e.mcap") == [
        f"{tmp_path / 'e.mcap'}: empty file; expected an MCAP recording"
    ]
    (tmp_path / "x.mcap").write_bytes(b"not an mcap at all")
    assert validate_session(tmp_path / "x.mcap") == [
        f"{tmp_path / 'x.mcap'}: not an MCAP file (bad magic); expected an MCAP recording"
    ]


def test_unix_times_against_gps_tow(sample_dir: Path) -> None:
    path = sample_dir / "nav_A.csv"
    path.write_text(path.read_text().replace("\n4320", "\n16336512"))
    problems = _problems(sample_dir)
    assert any(
        "nav_A.csv: times 1633651200.000..1633651204.900 look like Unix seconds; "
        'expected GPS seconds of week (0..604800) as [time] base = "gps_tow" says' in p
        for p in problems
    )


def test_unknown_session_toml_key(sample_dir: Path) -> None:
    _edit(sample_dir / "session.toml", "base = ", "bse = ")
    (msg,) = _problems(sample_dir)
    assert msg.endswith("session.toml [time]: unknown key 'bse' (did you mean 'base'?)")
    with pytest.raises(ConfigError):
        read_session(sample_dir)


def test_unknown_session_toml_table_and_bad_value(sample_dir: Path) -> None:
    _edit(sample_dir / "session.toml", "[uwb]", "[uwbb]")
    assert validate_session(sample_dir)[0].endswith(
        "session.toml: unknown key 'uwbb' (did you mean 'uwb'?)"
    )
    _edit(sample_dir / "session.toml", "[uwbb]", "[uwb]")
    _edit(sample_dir / "session.toml", 'role = "leader"', 'role = "leeder"')
    assert validate_session(sample_dir)[0].endswith(
        "session.toml [platforms.B] role: 'leeder' is not one of "
        "'follower' | 'leader' | 'anchor' | 'tag'"
    )


def test_bad_pos_epoch_line(sample_dir: Path) -> None:
    path = sample_dir / "ref_C.pos"
    lines = path.read_text().splitlines()
    lines[9] = lines[9].replace("2021/10/08 00:00:00.200", "2021/13/08 00:00:00.200")
    path.write_text("\n".join(lines) + "\n")
    (msg,) = _problems(sample_dir)
    assert msg.startswith(f"{path}:10: time '2021/13/08 00:00:00.200'; expected 'YYYY/MM/DD")


def test_several_problems_all_reported(sample_dir: Path) -> None:
    _line(sample_dir / "ranges.csv", 2, "432000.000000,A,A,-5.0,,-80.0")
    _edit(sample_dir / "nav_B.csv", "time,east,north,", "time,east,nroth,")
    _edit(sample_dir / "session.toml", "[uwb]", "[uwbb]")
    problems = validate_session(sample_dir)
    assert len(problems) >= 4
    assert any("negative" in p for p in problems) and any("itself" in p for p in problems)
    assert any("nroth" in p for p in problems) and any("uwbb" in p for p in problems)


def test_not_a_session(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="no such file or directory"):
        read_session(tmp_path / "missing")
    (tmp_path / "notes.txt").write_text("x")
    with pytest.raises(InputError, match=r"expected a session directory or an \.mcap file"):
        read_session(tmp_path / "notes.txt")
    assert validate_session(tmp_path) == [
        f"{tmp_path}: no navigation files; expected nav_<ID>.csv (or .mcap /<ID>/nav)",
        f"{tmp_path}: no ranges; expected ranges.csv (or .mcap /uwb/range)",
    ]


def test_cli_validate_and_info(sample_dir: Path) -> None:
    runner = CliRunner()
    ok = runner.invoke(main, ["validate", str(sample_dir)])
    assert ok.exit_code == 0 and ok.output == f"{sample_dir}: ok\n"
    info = runner.invoke(main, ["info", str(sample_dir)])
    assert info.exit_code == 0
    assert "A  follower      50  432000.000  432004.900   10.000     0" in info.output
    assert "C-X       5  432000.000  432004.000    1.000     0" in info.output
    _line(sample_dir / "ranges.csv", 2, "432000.000000,A,A,-5.0,,-80.0")
    bad = runner.invoke(main, ["validate", str(sample_dir)])
    assert bad.exit_code == 1
    assert bad.output.splitlines()[:2] == [
        f"{sample_dir / 'ranges.csv'}:2: range -5.0 m is negative; expected 0..2000 m",
        f"{sample_dir / 'ranges.csv'}:2: platform A ranges to itself; "
        "expected two different platforms",
    ]
    err = runner.invoke(main, ["info", str(sample_dir)])
    assert err.exit_code == 1 and "Traceback" not in err.output
    assert err.output.startswith("error: ") and err.output.count("\n") == 1


def test_mcap_mapping_and_files_keys_are_checked(sample_dir: Path) -> None:
    toml = sample_dir / "session.toml"
    toml.write_text(toml.read_text() + '\n[mcap]\nrange_topc = "/uwb"\n')
    assert validate_session(sample_dir) == [
        f"{toml} [mcap]: unknown key 'range_topc' (did you mean 'range_topic'?)"
    ]
    toml.write_text(toml.read_text().replace("[mcap]\nrange_topc", '[files]\nrange = "r.csv"\n#'))
    assert validate_session(sample_dir) == [
        f"{toml} [files]: unknown key 'range' (did you mean 'ranges'?)"
    ]
    toml.write_text(toml.read_text().replace('range = "r.csv"', 'ranges = "uwb.csv"'))
    (sample_dir / "ranges.csv").rename(sample_dir / "uwb.csv")
    assert validate_session(sample_dir) == []
    assert read_session(sample_dir).ranges.source.endswith("uwb.csv")
