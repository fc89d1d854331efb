"""What more than one method family's room takes: the range table's checks and arrays
(:mod:`~coopproc.stages.shared.data`), the robust least-squares fix from anchors
(:mod:`~coopproc.stages.shared.lsq`), the start of the fusion, the INS, the odometer filter
and the anchors' methods, and the navigation corrected by the fusion's DR states
(:mod:`~coopproc.stages.shared.dr_corrected`), which the ranging stage's DR DI and the
fusion's ``cp_state = "corrected"`` solution take. It imports no room (tests/test_layout.py)."""
