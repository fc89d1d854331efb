"""Range processors of paper 000: DI, DI smoothing, the distance filter with NLOS
detection and estimation (DI-Based), and the RN-Based reference method."""
