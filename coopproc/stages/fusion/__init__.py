"""The cooperative fusion: the centralized EKF over every moving platform with IGG-III and
RTS smoothing (papers 002, 003), its self-calibration, its leave-pair-out folds and the
dead-reckoning quality check."""
