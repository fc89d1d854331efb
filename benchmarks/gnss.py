"""Benchmark GPS single-point positioning (``coopproc spp``) on the real GEONET files.

For each station of ``../shared/data/gnss`` (0759 and 3040, 2005 day 092, 120 epochs at
30 s): reading the RINEX observation and navigation files, and ``solve_spp`` with the
default options and with ``--raim``; each the median of ``--repeat`` runs after a
warm-up, as epochs/s, with the median 3-D and horizontal error against the header
position (the accuracy the SPP test asserts: <= 5 m and <= 3 m).

Then the tightly coupled filter (``tight``, issue 13 item 4) on a simulated session
(``anchors`` scenario, seed 0, 600 s, the tag's GPS at 1 Hz and about 4 UWB ranges/s
to four anchors, written and read back as files): GPS-only (``gnss``) and GPS/UWB
(``tight``), robust, with the constant-velocity model and with paper 002's INS error
states (the tag's 100 Hz IMU mechanised in between), as GPS epochs/s wall and per CPU
second (the UWB updates in between included), with the tag's horizontal RMS error
against the reference.

    python benchmarks/gnss.py [--repeat 5] [--data ../shared/data/gnss]
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

import numpy as np
from _common import load, median_seconds, spread

from coopproc import frames
from coopproc.gnss.rinex_nav import read_nav
from coopproc.gnss.rinex_obs import read_obs
from coopproc.gnss.spp import SppOptions, solve_spp

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "gnss"


def errors(ecef: np.ndarray, reference: np.ndarray) -> tuple[float, float]:
    """Median 3-D and horizontal error (m) of ``ecef`` against ``reference``."""
    llh = frames.ecef2geodetic(reference[None, :])[0]
    enu = frames.ecef2enu(ecef, (llh[0], llh[1], llh[2]))
    return (
        float(np.median(np.linalg.norm(enu, axis=1))),
        float(np.median(np.hypot(enu[:, 0], enu[:, 1]))),
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--data", type=Path, default=DATA)
    args = parser.parse_args()
    stations = sorted(p.name[:4] for p in args.data.glob("*0920.05o"))
    if not stations:
        raise SystemExit(f"no GEONET observation files in {args.data}")
    for station in stations:
        obs_path = args.data / f"{station}0920.05o"
        nav_path = args.data / f"{station}0920.05n"
        read_s, read_times = median_seconds(
            lambda o=obs_path, n=nav_path: (read_obs(o), read_nav(n)), args.repeat
        )
        obs, eph = read_obs(obs_path), read_nav(nav_path)
        n = obs.epoch_gpst_s.size
        print(
            f"{station}: {n} epochs, {obs.prn.size} observations; read obs+nav "
            f"{read_s * 1e3:.1f} ms ({spread(read_times)}; {load()})"
        )
        assert obs.approx_position_ecef_m is not None
        for label, options in (
            ("spp", SppOptions()),
            ("spp --raim", replace(SppOptions(), raim=True)),
        ):
            seconds, times = median_seconds(
                lambda o=options, b=obs, e=eph: solve_spp(b, e, o), args.repeat
            )
            sol = solve_spp(obs, eph, options)
            e3, eh = errors(sol.ecef_m, obs.approx_position_ecef_m)
            print(
                f"  {label:<11} {n / seconds:8.0f} epochs/s ({spread(times)}); "
                f"median error 3-D {e3:.2f} m, horizontal {eh:.2f} m; {load()}"
            )
    tight(args.repeat)


def tight(repeat: int) -> None:
    """The tight filter's throughput on a simulated session (module docstring)."""
    import tempfile
    import time

    from coopproc.io.session import read_session
    from coopproc.sim import simulate, write_simulation
    from coopproc.stages.gnss.tight_stage import GnssParams, solve

    with tempfile.TemporaryDirectory(prefix="coopproc-bench-") as tmp:
        path = Path(tmp) / "anchors"
        write_simulation(simulate("anchors", seed=0, gnss_obs=True, imu_rate_hz=100), path)
        session = read_session(path)
    epochs = session.gnss["tag"].epoch_time_s.size
    ranges = len(session.ranges.frame)
    imu = session.imu["tag"].time_s.size
    print(
        f"tight: anchors seed 0, {epochs} GPS epochs of the tag, {ranges} UWB ranges, "
        f"{imu} IMU samples (100 Hz)"
    )
    ref = session.reference["tag"]
    for label, uwb, ins in (
        ("gnss", False, False),
        ("tight", True, False),
        ("gnss+INS", False, True),
        ("tight+INS", True, True),
    ):
        params = GnssParams(ins=ins)
        seconds, times = median_seconds(
            lambda u=uwb, p=params: solve(session, session.ranges.frame, p, u, True), repeat
        )
        cpu = time.process_time()
        out, _ = solve(session, session.ranges.frame, params, uwb, True)
        cpu = time.process_time() - cpu
        t = np.asarray(out["tag"].time_s)
        err = np.asarray(out["tag"].state)[:, :2] - ref.interpolate_within(t)[:, :2]
        rms = float(np.sqrt(np.nanmean(np.sum(err**2, axis=1))))
        print(
            f"  {label:<9} {epochs / seconds:8.0f} GPS epochs/s wall ({spread(times)}), "
            f"{epochs / cpu:8.0f} per CPU s; horizontal RMS {rms:.2f} m; {load()}"
        )


if __name__ == "__main__":
    main()
