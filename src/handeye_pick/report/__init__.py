"""The shift report: what a cell did, read from its audit file alone (``handeye-pick report``).

``lines`` streams the file record by record, ``shift`` folds the records into bounded tallies
(counts, picks per hour, cycle times, faults and halts) and the finished ``ShiftReport``,
``text`` prints it for a person and ``plot`` draws it on one PNG. The definitions (what a cycle
is, what its time is, how halted time is measured) are in docs/report.md.
"""
