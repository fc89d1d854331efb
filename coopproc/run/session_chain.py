"""The chain for one session: ``[pipeline]`` and what the session has, resolved in one place.

:func:`coopproc.run.chain.resolve` orders the steps ``[pipeline]`` names. What a session
adds or takes away comes first, each family's rule in turn, every decision a note:

1. tags (:mod:`coopproc.run.tags`): platforms without navigation get the UWB-only
   estimators, and the dead-reckoning stages run without them;
2. odometers (:mod:`coopproc.run.odo_methods`): ``odo_uwb``, ``odo_uwb_rts``;
3. anchors (:func:`coopproc.run.tags.anchor_pipeline`): ``lsq``, ``lsq_rts`` as comparison
   rows for platforms with navigation that range to anchors;
4. IMUs (:mod:`coopproc.run.ins`): the INS modes, and ``[ins] navigation = "ins"``;
5. GPS observations (:mod:`coopproc.run.gnss_methods`): ``gnss``, ``tight``.

Each registry entry declares the session capabilities it needs
(:data:`coopproc.stages.base.CAPABILITIES`, its ``requires``); :func:`chain_report` prints
the resolved chain with them against the session's (``coopproc config --session DIR``).
The run (:func:`coopproc.run.pipeline.run_pipeline`) takes its steps from
:func:`resolve_session`, so what ``config --session`` shows is what runs.
"""

from __future__ import annotations

from dataclasses import dataclass

from coopproc.model import Session
from coopproc.run.chain import PipelineParams, Step, chain_lines, resolve
from coopproc.run.config import RunConfig
from coopproc.run.gnss_methods import gnss_pipeline
from coopproc.run.ins import with_ins
from coopproc.run.odo_methods import odo_pipeline
from coopproc.run.tags import anchor_pipeline, tag_pipeline, without_tags
from coopproc.stages.base import session_capabilities
from coopproc.stages.registry import POSITION_STAGES, RANGE_STAGES

__all__ = ["SessionChain", "chain_report", "resolve_session"]


@dataclass(frozen=True)
class SessionChain:
    """The resolved chain of one session."""

    #: the session the stages see (``[ins] navigation = "ins"`` replaces navigation)
    session: Session
    #: the same without its tags and their ranges (the dead-reckoning stages' session)
    dr_session: Session
    #: ``[pipeline]`` as the session's families left it
    pipeline: PipelineParams
    steps: tuple[Step, ...]
    #: what the families added or left out, and why, in the order they decided
    notes: tuple[str, ...]


def resolve_session(config: RunConfig, session: Session) -> SessionChain:
    """The chain of ``config``'s ``[pipeline]`` on ``session`` (module doc)."""
    pipeline, notes = tag_pipeline(config.pipeline, session)
    pipeline, odo_notes = odo_pipeline(pipeline, session, config.params_for("odo_uwb"))
    pipeline, anchor_notes = anchor_pipeline(pipeline, session)
    session, pipeline, more = with_ins(session, pipeline, config.params_for("ins"))
    pipeline, more = gnss_pipeline(pipeline, session, config.params_for("gnss"), more)
    return SessionChain(
        session=session,
        dr_session=without_tags(session),
        pipeline=pipeline,
        steps=resolve(pipeline),
        notes=(*notes, *odo_notes, *anchor_notes, *more),
    )


def chain_report(chain: SessionChain) -> list[str]:
    """The chain's steps, each with the capabilities its stage requires, then the
    session's capabilities and the families' notes: what ``config --session`` prints."""
    have = session_capabilities(chain.session)
    lines = []
    for step, line in zip(chain.steps, chain_lines(chain.steps), strict=True):
        stage = (RANGE_STAGES if step.kind == "ranges" else POSITION_STAGES)[step.stage]
        needs = ", ".join(sorted(stage.requires)) or "nothing"
        missing = sorted(stage.requires - have)
        lines.append(
            f"{line}  [needs {needs}" + (f"; MISSING {', '.join(missing)}]" if missing else "]")
        )
    lines.append("session has: " + (", ".join(sorted(have)) or "none of the capabilities"))
    lines += [f"note: {n}" for n in chain.notes]
    return lines
