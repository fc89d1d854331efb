"""PhaseProgress: per-phase timings and log lines (a fake clock)."""

from __future__ import annotations

from coopproc.run.progress import PhaseProgress


def test_phases_are_timed_and_logged_with_elapsed_time() -> None:
    now = [10.0]
    lines: list[str] = []
    with PhaseProgress(3, bar=False, log=lines.append, prefix="run", clock=lambda: now[0]) as p:
        p.start("read")
        now[0] = 12.5
        p.start("fusion")
        now[0] = 13.0
        p.end()
        now[0] = 20.0  # idle time between phases belongs to none
        p.start("fusion")  # a phase run again adds up
        now[0] = 21.0
    assert p.timings_s == {"read": 2.5, "fusion": 1.5}
    assert lines == [
        "run: read done in 2.5 s (elapsed 2.5 s)",
        "run: fusion done in 0.5 s (elapsed 3.0 s)",
        "run: fusion done in 1.0 s (elapsed 11.0 s)",
    ]


def test_an_error_logs_no_line_for_the_unfinished_phase() -> None:
    lines: list[str] = []
    try:
        with PhaseProgress(2, bar=False, log=lines.append) as p:
            p.start("read")
            raise RuntimeError("boom")
    except RuntimeError:
        pass
    assert lines == []
    quiet = PhaseProgress(1, bar=False, log=None)
    quiet.start("x")
    quiet.close()
    assert set(quiet.timings_s) == {"x"}


def test_the_bar_total_follows_what_is_known_after_reading(capsys) -> None:  # type: ignore[no-untyped-def]
    # steps run two at a time are one phase: the bar is told after reading
    with PhaseProgress(12, bar=True, log=None) as p:
        p.start("read")
        p.set_total(11)
        assert p._bar.total == 11
        for label in ("prepare", "fusion (rn, di)"):
            p.start(label)
        assert p._bar.n == 2
    assert set(p.timings_s) == {"read", "prepare", "fusion (rn, di)"}
