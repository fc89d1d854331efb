"""Issue 14 item 2: CSV as people export it reads as the plain session, bad forms fail in one line.

Each form rewrites the small io session (tests/io/conftest.py) or the shipped sample at
the text level and must give the same session (``read_session``) as the plain files, or
byte-identical ``coopproc run`` tables; the copies and backups of item 6 must be left out
with a note, not become platforms.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from coopproc.cli import main
from coopproc.io import read_session, validate_session

sys.path.insert(0, str(Path(__file__).parent))
from csv_export_kit import REPO, TUC, add_toml, assert_same, notes, rewrite

# -- 1. delimiters, decimal commas ---------------------------------------------------


@pytest.mark.parametrize(
    ("sep", "said"),
    [(";", "';'-delimited"), ("\t", "tab-delimited"), ("|", "'|'-delimited"), (" ", "whitespace")],
)
def test_delimiters_read_as_the_plain_session(sample_dir: Path, sep: str, said: str) -> None:
    plain = read_session(sample_dir)
    ranges = sample_dir / "ranges.csv"
    if sep == " ":  # whitespace cannot leave a cell empty: 'not given' is NaN
        ranges.write_text(ranges.read_text().replace(",,", ",NaN,"))
    for name in ("nav_A.csv", "nav_B.csv", "ranges.csv"):
        rewrite(sample_dir / name, sep=sep)
    other = read_session(sample_dir)
    assert_same(plain, other)
    assert f"{sample_dir / 'nav_B.csv'}: read as {said}" in notes(other)
    assert "nav_C.csv: read as" not in notes(other)  # a comma file gets no note


def test_semicolon_with_decimal_commas(sample_dir: Path) -> None:
    plain = read_session(sample_dir)
    for name in ("nav_A.csv", "ranges.csv"):
        rewrite(sample_dir / name, sep=";", decimal_comma=True)
    other = read_session(sample_dir)
    assert_same(plain, other)
    assert "ranges.csv: read as ';'-delimited with decimal commas" in notes(other)
    assert float(other.ranges.frame["rssi"].iloc[1]) == -79.5  # carried, as a number


def test_whitespace_row_with_a_missing_cell_is_one_error(sample_dir: Path) -> None:
    rewrite(sample_dir / "ranges.csv", sep=" ")  # the empty sigma cells vanish
    (msg,) = validate_session(sample_dir)
    assert msg.startswith(f"{sample_dir / 'ranges.csv'}:2: 5 fields, expected 6 (whitespace")


# -- 2. encodings --------------------------------------------------------------------


@pytest.mark.parametrize("encoding", ["utf-8-sig", "utf-16", "utf-16-be", "utf-32"])
def test_byte_order_marks(sample_dir: Path, encoding: str) -> None:
    plain = read_session(sample_dir)
    for name in ("nav_A.csv", "ranges.csv"):
        path = sample_dir / name
        text = "# Höhe über NN, Kurs in °\n" + path.read_text()
        data = text.encode(encoding)
        path.write_bytes(data if encoding != "utf-16-be" else b"\xfe\xff" + data)
    other = read_session(sample_dir)
    assert_same(plain, other)
    if encoding != "utf-8-sig":
        assert f"ranges.csv: read as UTF-{encoding[4:6]} (byte order mark)" in notes(other)


def test_declared_encodings_session_wide_and_per_file(sample_dir: Path) -> None:
    plain = read_session(sample_dir)
    rewrite(sample_dir / "ranges.csv", sep=";", encoding="cp1252", comment="# Entfernung – m")
    rewrite(sample_dir / "nav_A.csv", encoding="latin-1", comment="# Höhe ±0,05 m")
    add_toml(sample_dir, '[files]\nencoding = "cp1252"\n[files.encodings]\nnav.A = "latin-1"\n')
    other = read_session(sample_dir)
    assert_same(plain, other)
    text = notes(other)
    assert "ranges.csv: read as cp1252 (session.toml [files] encoding), ';'-delimited" in text
    assert "nav_A.csv: read as latin-1 (session.toml [files.encodings] nav.A)" in text


def test_undeclared_cp1252_is_one_error_naming_line_and_byte(sample_dir: Path) -> None:
    path = sample_dir / "nav_B.csv"
    lines = path.read_text().splitlines()
    lines.insert(0, "# exported")
    lines.insert(1, "# Höhe")  # line 2, column 4
    path.write_bytes("\n".join(lines).encode("cp1252"))
    assert validate_session(sample_dir) == [
        f"{path}:2: byte 0xf6 (column 4) does not decode as utf-8 (invalid start byte); "
        "expected UTF-8 text, or the file's encoding in session.toml, e.g. "
        '[files] encoding = "cp1252"'
    ]


def test_bytes_the_declared_encoding_lacks_and_bomless_utf16(sample_dir: Path) -> None:
    add_toml(sample_dir, '[files]\nencoding = "cp1252"\n')
    nav = sample_dir / "nav_C.csv"
    data = nav.read_bytes().split(b"\n")
    data[3] = data[3] + b",\x81"  # 0x81 is undefined in cp1252
    nav.write_bytes(b"\n".join(data))
    (sample_dir / "ranges.csv").write_bytes(
        (sample_dir / "ranges.csv").read_text().encode("utf-16-le")
    )
    problems = validate_session(sample_dir)
    assert problems[0].startswith(f"{nav}:4: byte 0x81 (column ")
    assert problems[0].endswith(
        "does not decode as cp1252 (character maps to <undefined>); expected text in cp1252 "
        "as session.toml [files] encoding says"
    )
    assert problems[1].startswith(
        f"{sample_dir / 'ranges.csv'}:1: holds NUL bytes: looks like UTF-16"
    )


# -- 3. letter case of names ---------------------------------------------------------


def test_upper_case_names(sample_dir: Path) -> None:
    plain = read_session(sample_dir)
    for old, new in (
        ("nav_A.csv", "NAV_A.CSV"),
        ("nav_B.csv", "nav_B.Csv"),
        ("ref_C.pos", "REF_C.POS"),
        ("ranges.csv", "Ranges.CSV"),
    ):
        (sample_dir / old).rename(sample_dir / new)
    other = read_session(sample_dir)
    assert_same(plain, other)
    assert {p.name for p in other.inputs} >= {"NAV_A.CSV", "nav_B.Csv", "REF_C.POS", "Ranges.CSV"}
    shutil.copy(sample_dir / "Ranges.CSV", sample_dir / "RANGES.csv")
    problems = validate_session(sample_dir)
    assert (
        problems[0] == f"{sample_dir}: several ranges files (RANGES.csv, Ranges.CSV); expected one"
    )


# -- 4. extra columns ----------------------------------------------------------------


def test_extra_nav_columns_are_ignored_with_a_note(sample_dir: Path) -> None:
    plain = read_session(sample_dir)
    path = sample_dir / "nav_A.csv"
    lines = path.read_text().splitlines()
    lines = [lines[0] + ",roll,pitch,sats"] + [line + ",0.1,-0.2,12" for line in lines[1:]]
    path.write_text("\n".join(lines) + "\n")
    other = read_session(sample_dir)
    assert_same(plain, other)
    assert f"{path}: column(s) 'roll', 'pitch', 'sats' ignored (not nav/ref columns)" in notes(
        other
    )
    # a misspelling of a column the file lacks stays an error: it would be lost silently
    path.write_text(path.read_text().replace("heading,", "headng,", 1))
    assert f"{path}: unknown column 'headng' (did you mean 'heading'?)" in validate_session(
        sample_dir
    )


# -- through the CLI: the exported sample gives byte-identical run tables -------------


def _trimmed_sample(dst: Path, seconds: float = 30.0) -> Path:
    """sample_logs cut to its first ``seconds`` (a quick run), plain form."""
    src = REPO / "sample_logs"
    dst.mkdir()
    shutil.copy(src / "session.toml", dst)
    end = 108000.0 + seconds
    for f in src.glob("*.csv"):
        head, *rows = f.read_text().splitlines(keepends=True)
        (dst / f.name).write_text(head + "".join(r for r in rows if float(r[:13]) < end))
    for f in src.glob("*.pos"):
        lines = f.read_text().splitlines(keepends=True)
        keep = [line for line in lines if line.startswith("%")]
        keep += [line for line in lines if not line.startswith("%")][: int(seconds * 5) + 1]
        (dst / f.name).write_text("".join(keep))
    return dst


_EXPORTED = """
[files]
encoding = "cp1252"
ranges = "UWB-Log.CSV"
nav.A = "robotA_odom.csv"
nav.B = "robotB_odom.csv"
nav.C = "robotC_odom.csv"
ref.A = "A_ppk.pos"
[columns]
time = "Zeit"
heading = "Kurs (°)"
[columns.units]
time = "ms"
[columns.ranges]
from = "Sender"
to = "Empfänger"
range = "Abstand"
sigma = "σ"
[columns.ranges.units]
range = "mm"
"""


def test_exported_sample_runs_to_byte_identical_tables(tmp_path: Path) -> None:
    plain = _trimmed_sample(tmp_path / "plain")
    exported = tmp_path / "exported"
    shutil.copytree(plain, exported)
    for pid in "ABC":
        rewrite(
            exported / f"nav_{pid}.csv",
            sep=";",
            decimal_comma=True,
            encoding="cp1252",
            comment="# Exportiert: Odometrie über Zeit (ms)",
            header={"time": "Zeit", "heading": "Kurs (°)"},
            scale={"time": 3},
            dst=exported / f"robot{pid}_odom.csv",
        )
    rewrite(
        exported / "ranges.csv",
        sep="\t",
        decimal_comma=True,
        encoding="utf-16",  # its byte order mark wins over the declared cp1252
        header={"time": "Zeit", "from": "Sender", "to": "Empfänger", "range": "Abstand"},
        scale={"time": 3, "range": 3, "sigma": 3},
        dst=exported / "UWB-Log.CSV",
    )
    text = (exported / "UWB-Log.CSV").read_text(encoding="utf-16")
    (exported / "UWB-Log.CSV").write_text(text.replace("\tsigma\t", "\tσ\t", 1), "utf-16")
    (exported / "ref_A.pos").rename(exported / "A_ppk.pos")
    (exported / "ref_C.pos").rename(exported / "REF_C.POS")
    shutil.copy(exported / "robotA_odom.csv", exported / "nav_A_backup.csv")
    add_toml(exported, _EXPORTED)
    runner = CliRunner()
    res = runner.invoke(main, ["validate", str(exported)])
    assert res.exit_code == 0 and res.output.endswith(": ok (1 warning)\n"), res.output
    outs = {}
    for name, root in (("plain", plain), ("exported", exported)):
        outs[name] = tmp_path / f"out_{name}"
        res = runner.invoke(main, ["run", str(root), "-o", str(outs[name]), "--no-figures"])
        assert res.exit_code == 0, res.output
    tables = sorted(p.name for p in outs["plain"].glob("*.csv"))
    assert "ranges.csv" in tables and "positions.csv" in tables
    for name in tables:
        assert (outs["plain"] / name).read_bytes() == (outs["exported"] / name).read_bytes(), name


def test_a_bad_form_is_one_line_through_the_cli(sample_dir: Path) -> None:
    path = sample_dir / "ranges.csv"
    path.write_bytes(path.read_bytes().replace(b"-79.5", b"\xe9-79.5"))
    for command in ("validate", "run"):
        res = CliRunner().invoke(
            main,
            [command, str(sample_dir), "-o", str(sample_dir / "o")][
                : 2 if command == "validate" else 4
            ],
        )
        assert res.exit_code == 1
        lines = [line for line in res.output.splitlines() if "ranges.csv" in line]
        assert lines == [
            f"{'error: ' if command == 'run' else ''}{path}:3: byte 0xe9 (column 29) does not "
            "decode as utf-8 (invalid continuation byte); expected UTF-8 text, or the file's "
            'encoding in session.toml, e.g. [files] encoding = "cp1252"'
        ], res.output


# -- real recordings -----------------------------------------------------------------


@pytest.mark.skipif(not TUC.exists(), reason="../shared/data is absent (a user's clone)")
def test_real_tuc_session_exported_reads_the_same(tmp_path: Path) -> None:
    root = shutil.copytree(TUC, tmp_path / "tuc")
    plain = read_session(root)
    rewrite(
        root / "nav_robot.csv",
        sep="\t",
        encoding="cp1252",
        comment="# Odometrie – Räder",
        dst=root / "NAV_robot.CSV",
    )
    rewrite(root / "ref_robot.csv", sep=" ", dst=root / "ref_robot.Csv")
    rewrite(
        root / "ranges.csv",
        sep=";",
        decimal_comma=True,
        encoding="utf-8-sig",
        scale={"range": 3, "sigma": 3},
    )
    add_toml(root, '[files]\nencoding = "cp1252"\n[columns.ranges.units]\nrange = "mm"\n')
    other = read_session(root)
    assert_same(plain, other, exact=False)  # 2955.2 mm -> m is within an ulp, not exact
    assert np.array_equal(other.nav["robot"].enu_m, plain.nav["robot"].enu_m)
    assert len(other.ranges) == 233
