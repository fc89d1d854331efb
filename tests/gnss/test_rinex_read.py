"""RINEX readers: RINEX 2 and 3 navigation and observation files read to the same numbers,
and one-line errors naming file and line for malformed or truncated files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from coopproc.errors import InputError
from coopproc.gnss.rinex_nav import read_nav, read_navs
from coopproc.gnss.rinex_obs import read_obs


def _h(text: str, label: str) -> str:
    return f"{text:<60}{label}\n"


# the first record of GEONET 07590920.05n (PRN 1, 2005-04-02 02:00)
RECORD_V2 = """\
 1 05  4  2  2  0  0.0 3.966595977540D-04 1.705302565820D-12 0.000000000000D+00
    1.400000000000D+02-5.218750000000D+01 4.026596389650D-09 2.871534990340D+00
   -2.676621079440D-06 5.957618006510D-03 4.174187779430D-06 5.153636478420D+03
    5.256000000000D+05 1.061707735060D-07-2.493184817740D+00-9.313225746150D-08
    9.833919144490D-01 3.093750000000D+02-1.650496813270D+00-7.889971342930D-09
   -8.571785642400D-12 1.000000000000D+00 1.316000000000D+03 0.000000000000D+00
    1.000000000000D+00 0.000000000000D+00-3.259629011150D-09 3.960000000000D+02
    5.195760000000D+05
"""

NAV_V2 = (
    _h("     2.10           N: GPS NAV DATA", "RINEX VERSION / TYPE")
    + _h("    1.1180D-08  1.4900D-08 -5.9600D-08 -5.9600D-08", "ION ALPHA")
    + _h("    8.8060D+04  1.6380D+04 -1.9660D+05 -1.3110D+05", "ION BETA")
    + _h("", "END OF HEADER")
    + RECORD_V2
)


def _v3_record() -> str:
    lines = RECORD_V2.splitlines()
    first = "G01 2005 04 02 02 00 00" + lines[0][22:].replace("D", "E")
    rest = ["    " + line[3:].replace("D", "E") for line in lines[1:]]
    return "\n".join([first, *rest]) + "\n"


GLONASS_V3 = (
    "R05 2005 04 02 02 15 00 1.000000000000E-05 0.000000000000E+00 0.000000000000E+00\n"
    + "     1.000000000000E+04 0.000000000000E+00 0.000000000000E+00 0.000000000000E+00\n" * 3
)

NAV_V3 = (
    _h("     3.04           N: GNSS NAV DATA    M: MIXED", "RINEX VERSION / TYPE")
    + _h("GPSA   1.1180E-08  1.4900E-08 -5.9600E-08 -5.9600E-08", "IONOSPHERIC CORR")
    + _h("GPSB   8.8060E+04  1.6380E+04 -1.9660E+05 -1.3110E+05", "IONOSPHERIC CORR")
    + _h("", "END OF HEADER")
    + GLONASS_V3
    + _v3_record()
)


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_nav_v2_and_v3_read_to_the_same_record(tmp_path: Path) -> None:
    v2 = read_nav(write(tmp_path, "a.05n", NAV_V2))
    v3 = read_nav(write(tmp_path, "b.rnx", NAV_V3))
    assert len(v2) == len(v3) == 1  # the GLONASS record is skipped
    for name in ("prn", "toc_gpst_s", "toe_gpst_s", "af0", "sqrt_a", "e", "omega", "tgd", "week"):
        np.testing.assert_array_equal(getattr(v2, name), getattr(v3, name), err_msg=name)
    assert v2.prn[0] == 1 and v2.week[0] == 1316 and v2.iode[0] == 140
    assert v2.sqrt_a[0] == pytest.approx(5153.636478420)
    assert v2.tgd[0] == pytest.approx(-3.259629011150e-09)
    # toc 2005-04-02 02:00 GPST = week 1316, 525600 s = toe
    assert v2.toc_gpst_s[0] == 1316 * 604800.0 + 525600.0 == v2.toe_gpst_s[0]
    assert v2.iono_alpha == v3.iono_alpha == (1.118e-08, 1.49e-08, -5.96e-08, -5.96e-08)
    assert v2.iono_beta == (88060.0, 16380.0, -196600.0, -131100.0)
    both = read_navs([tmp_path / "a.05n", tmp_path / "b.rnx"])
    assert len(both) == 1  # the same record once


def test_nav_truncated_record_names_its_line(tmp_path: Path) -> None:
    text = NAV_V2 + RECORD_V2.splitlines(keepends=True)[0] + "    1.0D+00\n"
    path = write(tmp_path, "t.05n", text)
    with pytest.raises(InputError, match=r"t\.05n:13: truncated: .* 2 of 8 lines") as err:
        read_nav(path)
    assert "\n" not in str(err.value)


def test_nav_malformed_number_names_its_line(tmp_path: Path) -> None:
    path = write(tmp_path, "m.05n", NAV_V2.replace("5.153636478420D+03", "5.15363647x420D+03"))
    with pytest.raises(InputError, match=r"m\.05n:7: field 4: '5\.15363647x420E\+03'"):
        read_nav(path)


def test_nav_of_an_observation_file_is_refused(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"o\.05o:1: RINEX type .*expected GPS navigation"):
        read_nav(write(tmp_path, "o.05o", OBS_V2))


OBS_V2 = (
    _h("     2.10           OBSERVATION DATA    G (GPS)", "RINEX VERSION / TYPE")
    + _h("0759", "MARKER NAME")
    + _h(" -3976219.5082  3382372.5671  3652512.9849", "APPROX POSITION XYZ")
    + _h("     6    L1    C1    L2    P2    S1    D1", "# / TYPES OF OBSERV")
    + _h("    30.0000", "INTERVAL")
    + _h("", "END OF HEADER")
    + " 05  4  2  0  0  0.0000000  0  2G 3G 7\n"
    + "  55923622.160    24767686.375    43647388.2424   24767684.8224          45.000\n"
    + "      -123.500\n"
    + "   -691177.898    24361933.475                    24361930.5994\n"
    + "\n"
    + " 05  4  2  0  0 30.0000000  4  1\n"
    + _h("a comment in the body", "COMMENT")
    + " 05  4  2  0  1  0.0000000  0  1G 3\n"
    + "  56220567.922    24824193.270    43878774.3064   24824191.9974\n"
    + "\n"
)

OBS_V3 = (
    _h("     3.04           OBSERVATION DATA    M: MIXED", "RINEX VERSION / TYPE")
    + _h("0759", "MARKER NAME")
    + _h(" -3976219.5082  3382372.5671  3652512.9849", "APPROX POSITION XYZ")
    + _h("G    6 L1C C1C L2W C2W S1C D1C", "SYS / # / OBS TYPES")
    + _h("R    1 C1C", "SYS / # / OBS TYPES")
    + _h("", "END OF HEADER")
    + "> 2005 04 02 00 00  0.0000000  0  3\n"
    + "G03  55923622.160    24767686.375    43647388.2424   24767684.8224          45.000"
    + "      -123.500\n"
    + "G07   -691177.898    24361933.475                    24361930.5994\n"
    + "R05  20000000.000\n"
    + "> 2005 04 02 00 01  0.0000000  0  1\n"
    + "G03  56220567.922    24824193.270    43878774.3064   24824191.9974\n"
)


def test_obs_v2_and_v3_read_to_the_same_numbers(tmp_path: Path) -> None:
    v2 = read_obs(write(tmp_path, "a.05o", OBS_V2))
    v3 = read_obs(write(tmp_path, "b.rnx", OBS_V3))
    # v2: the event-4 record (a comment) is skipped
    np.testing.assert_array_equal(v2.epoch_gpst_s - v2.epoch_gpst_s[0], [0.0, 60.0])
    np.testing.assert_array_equal(v2.epoch_gpst_s, v3.epoch_gpst_s)
    assert v2.epoch_gpst_s[0] == 1316 * 604800.0 + 518400.0  # Saturday 2005-04-02 00:00
    assert v2.prn.tolist() == [3, 7, 3] and v2.epoch_index.tolist() == [0, 0, 1]
    assert v2.epoch_line is not None and v2.epoch_line.tolist() == [7, 14]
    assert v3.epoch_line is not None and v3.epoch_line.tolist() == [7, 11]
    g = v3.system == "G"
    assert v3.system.tolist() == ["G", "G", "R", "G"]
    np.testing.assert_array_equal(v2.values["C1"], v3.values["C1C"][g])
    np.testing.assert_array_equal(v2.values["P2"], v3.values["C2W"][g])
    np.testing.assert_array_equal(v2.values["D1"], v3.values["D1C"][g])
    assert v2.values["C1"][0] == 24767686.375 and np.isnan(v2.values["L2"][1])
    assert v2.values["D1"][0] == -123.5 and np.isnan(v2.values["D1"][1])
    assert v3.values["C1C"][2] == 20000000.0
    assert v2.marker == "0759" and v2.interval_s == 30.0
    np.testing.assert_array_equal(
        v2.approx_position_ecef_m, [-3976219.5082, 3382372.5671, 3652512.9849]
    )
    np.testing.assert_array_equal(v2.code(("C1C", "C1")), v2.values["C1"])


def test_obs_truncated_epoch_names_its_line(tmp_path: Path) -> None:
    # header (6 lines), the epoch line, the first satellite, half of the second
    text = "".join(OBS_V2.splitlines(keepends=True)[:10])
    path = write(tmp_path, "t.05o", text)
    with pytest.raises(
        InputError, match=r"t\.05o:7: truncated: epoch has 1 of 2 satellites complete"
    ):
        read_obs(path)


def test_obs_malformed_epoch_and_number(tmp_path: Path) -> None:
    bad_epoch = write(
        tmp_path, "e.05o", OBS_V2.replace(" 05  4  2  0  1  0.0", " 05  4 x2  0  1  0.0")
    )
    with pytest.raises(InputError, match=r"e\.05o:14: epoch .*expected 'yy mm dd"):
        read_obs(bad_epoch)
    bad_value = write(tmp_path, "v.05o", OBS_V2.replace("24361933.475", "24361933.4x5"))
    with pytest.raises(InputError, match=r"v\.05o:10: observation 2 '24361933\.4x5'"):
        read_obs(bad_value)
    no_header_end = write(tmp_path, "h.05o", OBS_V2.split("END OF HEADER")[0][:-60])
    with pytest.raises(InputError, match=r"h\.05o:\d+: truncated header"):
        read_obs(no_header_end)
