"""The run machinery: the run config, the stage chain, output writing, the summary and
batch execution. It knows the stages only through :mod:`coopproc.stages.registry`."""
