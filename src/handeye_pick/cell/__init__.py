"""The cell session: the ``Cell`` and the sequences it runs (plan, check, move, audit)."""
