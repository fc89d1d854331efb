"""What more than one method family's room takes: the range table's checks and arrays
(:mod:`~coopproc.stages.shared.data`) and the robust least-squares fix from anchors
(:mod:`~coopproc.stages.shared.lsq`), the start of the fusion, the INS, the odometer filter
and the anchors' methods. It imports no room (tests/test_layout.py)."""
