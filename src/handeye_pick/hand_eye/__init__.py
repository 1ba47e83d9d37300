"""The hand-eye calibration's files (Zivid YAML, JSON, the cell config's form) and the checks
that they are plausible for the cell; below the config, the safety checks and the session that
read them."""
