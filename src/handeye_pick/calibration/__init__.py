"""Hand-eye calibration: its files, its plausibility, datasets, the solver and pose proposals."""
