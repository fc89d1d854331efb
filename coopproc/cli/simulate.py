"""``coopproc simulate OUT --scenario NAME``: write a simulated session with its truth."""

from __future__ import annotations

import inspect
import tomllib
from pathlib import Path
from typing import Any, Literal

import click

from coopproc.errors import ConfigError
from coopproc.sim import SCENARIOS, write_simulation
from coopproc.sim import simulate as run_simulation

__all__ = ["simulate"]


def _parse_set(items: tuple[str, ...]) -> dict[str, Any]:
    """``KEY=VALUE`` pairs, each VALUE read as a TOML value (bare words as strings)."""
    out: dict[str, Any] = {}
    for item in items:
        key, sep, text = item.partition("=")
        key = key.strip()
        if not sep or not key:
            raise ConfigError(f"--set {item!r}: expected KEY=VALUE")
        try:
            value = tomllib.loads(f"v = {text.strip()}")["v"]
        except tomllib.TOMLDecodeError:
            value = text.strip()
        out[key] = value
    return out


_SCENARIO_HELP = "\n".join(f"  {name}" for name in SCENARIOS)


@click.command()
@click.argument("out", type=click.Path(path_type=Path))
@click.option(
    "--scenario",
    required=True,
    type=click.Choice(sorted(SCENARIOS)),
    help="What to simulate.",
)
@click.option(
    "--seed", type=click.IntRange(min=0), default=0, show_default=True, help="Random seed (>= 0)."
)
@click.option("--duration", type=float, default=None, help="Session length, s (scenario default).")
@click.option("--platforms", type=int, default=None, help="Number of platforms (scenario default).")
@click.option(
    "--imu",
    "imu_rate",
    type=float,
    default=None,
    help="Also write imu_<ID>.csv at this rate, Hz (50-1000), and odo_<ID>.csv "
    "(= --set imu_rate_hz=RATE; grade: --set imu_grade=...).",
)
@click.option(
    "--gnss-obs",
    "gnss_obs",
    is_flag=True,
    default=None,
    help="Also write RINEX GPS observations obs_<ID>.rnx of every platform and nav.rnx "
    "(= --set gnss_obs=true; docs/simulator.md).",
)
@click.option(
    "--gnss-nav",
    "gnss_nav",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="RINEX navigation file the simulated satellites fly (= --set gnss_nav=FILE; "
    "default: the shared GEONET file).",
)
@click.option("--mcap", is_flag=True, help="Also write the session as one MCAP file in OUT/mcap/.")
@click.option(
    "--mcap-encoding",
    type=click.Choice(["json", "ros2"]),
    default="json",
    show_default=True,
    help="Message encoding of the MCAP file.",
)
@click.option("--force", is_flag=True, help="Replace OUT if it exists.")
@click.option(
    "--set",
    "settings",
    multiple=True,
    metavar="KEY=VALUE",
    help="Override one simulation parameter (see docs/simulator.md), e.g. --set uwb_noise_m=0.05.",
)
def simulate(
    out: Path,
    scenario: str,
    seed: int,
    duration: float | None,
    platforms: int | None,
    imu_rate: float | None,
    gnss_obs: bool | None,
    gnss_nav: Path | None,
    mcap: bool,
    mcap_encoding: Literal["json", "ros2"],
    force: bool,
    settings: tuple[str, ...],
) -> None:
    """Simulate a session with known truth into OUT (session files + OUT/truth/).

    The same scenario, options and seed give byte-identical files.
    """
    overrides = _parse_set(settings)
    for option, key, value in (
        ("--duration", "duration_s", duration),
        ("--platforms", "platforms", platforms),
        ("--imu", "imu_rate_hz", imu_rate),
        ("--gnss-obs", "gnss_obs", gnss_obs),
        ("--gnss-nav", "gnss_nav", None if gnss_nav is None else str(gnss_nav)),
    ):
        if value is not None and key in overrides:
            raise ConfigError(f"{option} and --set {key} both given: use one")
        overrides.setdefault(key, value)
    sim = run_simulation(scenario, seed=seed, **overrides)
    files = write_simulation(sim, out, mcap=mcap, force=force, mcap_encoding=mcap_encoding)
    session = sim.session
    click.echo(
        f"{out}: {scenario} seed {seed}, {sim.truth.params.duration_s:g} s, "
        f"{len(session.platforms)} platforms, {len(session.ranges)} ranges, "
        f"{len(sim.truth.nlos_events)} NLOS events, {len(files)} files"
    )


simulate.help = (
    inspect.cleandoc(simulate.help or "")
    + "\n\n\b\nScenarios (docs/simulator.md):\n"
    + _SCENARIO_HELP
)
