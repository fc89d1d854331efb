"""UWB-only positioning from fixed anchors: robust least-squares fixes, the fixes through a
constant-velocity KF and RTS smoother (``lsq``, ``lsq_kf``, ``lsq_rts``), and the ranges
straight into a constant-velocity EKF (``range_kf``, ``range_rts``); paper 003 sec. 2.2, 2.8."""
