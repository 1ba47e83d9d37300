"""Hand-eye calibration as a procedure: datasets, the solver, pose proposals and the collect
run that drives a cell (the files it writes and their plausibility are in ``hand_eye``)."""
