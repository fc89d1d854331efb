"""The INS position methods of paper 003 Table 1 (``ins``, ``ins_nhc``, ``ins_rts``,
``ins_nhc_rts``): the stage entry and the session's inputs to the INS engine, which stays
below the stages in :mod:`coopproc.ins`."""
