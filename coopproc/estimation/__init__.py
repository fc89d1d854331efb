"""The estimation layer: measurement, robust and smoother building blocks below the stages.

Not to be confused with :mod:`coopproc.model`, the data model (sessions, trajectories,
ranges). ``estimation`` holds the formulas the filters share: the IGG-III robust update
and MAD sigma (:mod:`.robust`), the linear Kalman predict/update and RTS step
(:mod:`.kalman`), compiled linear algebra (:mod:`.linalg`) and the results reporters
read (:mod:`.locate_result`). It imports only numpy, numba, scipy and the shared modules,
so the stages, the INS engine and the GNSS code may all build on it.
"""
