"""Position estimators: the centralized cooperative EKF with IGG-III and RTS smoothing
(papers 002, 003), its self-calibration, robust least squares from anchors (paper 003)
and the dead-reckoning quality check."""
