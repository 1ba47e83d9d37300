"""The shift report for a person (``report_text``) and as one JSON object (``report_json``), and
the one warning line for what was skipped (``skipped_warning``).

Times are ISO 8601 in the report's zone, with its offset; durations are seconds.
"""

from __future__ import annotations

from handeye_pick.report.shift import Fault, ShiftReport, counted

_ENDED_BY = {
    "resume": " until resume",
    "plan": " until a new session",
    None: ", still halted at the end",
}


def report_json(report: ShiftReport) -> dict[str, object]:
    """The report as plain JSON types; the same figures ``report_text`` prints."""
    cycle = report.cycle_times
    return {
        "audit": str(report.path),
        "since": _iso(report, report.since),
        "until": _iso(report, report.until),
        "start": _iso(report, report.start),
        "end": _iso(report, report.end),
        "span_s": report.span_s,
        "cycles": report.cycles,
        "statuses": report.statuses,
        "dry_runs": report.dry_runs,
        "places_done": report.places_done,
        "abandoned": report.abandoned,
        "faults": report.faults,
        "connect_faults": report.connect_faults,
        "stops": report.stops,
        "stop_requests": report.stop_requests,
        "interrupts": report.interrupts,
        "halts": report.halts,
        "halted_refusals": report.halted_refusals,
        "resumes": report.resumes,
        "resumes_not_ready": report.resumes_not_ready,
        "halted_s": report.halted_s,
        "halted_share": report.halted_share,
        "picks_per_hour": [
            {
                "hour": _iso(report, h.start),
                "picks": h.picks,
                "cycles": h.cycles,
                "faults": h.faults,
            }
            for h in report.hours
        ],
        "cycle_time_s": {
            "count": cycle.count,
            "median": cycle.median_s,
            "p90": cycle.p90_s,
            "histogram": {
                "low_s": cycle.low_s,
                "bin_s": cycle.bin_s,
                "counts": cycle.counts,
                "under": cycle.under,
                "over": cycle.over,
            },
        },
        "fault_list": [_fault_json(report, fault) for fault in report.fault_list],
        "faults_left_out": report.faults_left_out,
        "skipped": {
            "torn_lines": report.torn,
            "unknown_kinds": report.unknown_kinds,
            "bad_records": report.bad_records,
        },
    }


def _fault_json(report: ShiftReport, fault: Fault) -> dict[str, object]:
    return {
        "time": _iso(report, fault.time),
        "status": fault.status,
        "operation": fault.operation,
        "step": fault.step,
        "reason": fault.reason,
        "request_id": fault.request_id,
        "pick_id": fault.pick_id,
        "started_halt": fault.started_halt,
        "stood_s": _stood_s(report, fault),
        "ended_by": fault.ended_by if fault.started_halt else None,
    }


def report_text(report: ShiftReport) -> str:
    """The report as lines for a terminal."""
    lines = [
        f"shift report of {report.path}",
        f"  from {_clock(report, report.start)} to {_clock(report, report.end)} "
        f"({_duration(report.span_s)})",
        f"  pick outcomes {report.cycles}: "
        + ", ".join(f"{status} {n}" for status, n in report.statuses.items()),
        f"  places after a pick {report.places_done}, dry runs {report.dry_runs}, "
        f"abandoned {report.abandoned}",
        f"  faults {report.faults}"
        + (f" ({report.connect_faults} failing to connect)" if report.connect_faults else "")
        + f", stops {report.stops} ({counted(report.stop_requests, 'stop request')}, "
        f"{report.interrupts} Ctrl-C or SIGTERM), halts {report.halts} "
        f"(halted {_duration(report.halted_s)}, {100.0 * report.halted_share:.1f} % of the time), "
        f"refused while halted {report.halted_refusals}, resumes {report.resumes} "
        f"(+{report.resumes_not_ready} not ready)",
    ]
    cycle = report.cycle_times
    if cycle.median_s is not None and cycle.p90_s is not None:
        lines.append(
            f"  cycle time (s, {cycle.count} intervals): median {cycle.median_s:.2f}, "
            f"p90 {cycle.p90_s:.2f}"
        )
        lines += _histogram_lines(report)
    if report.hours:
        lines.append("  picks per hour:")
        lines += [
            f"    {_clock(report, h.start)}  {counted(h.picks, 'pick', 5):11}  "
            f"{counted(h.cycles, 'outcome', 5):14}"
            + (f"  {counted(h.faults, 'fault', 5)}" if h.faults else "")
            for h in report.hours
        ]
    if report.fault_list:
        lines.append(
            "  faults and stop requests (time, status, operation/step, how long the cell stood, "
            "reason):"
        )
        lines += [_fault_line(report, fault) for fault in report.fault_list]
    if report.faults_left_out:
        lines.append(
            f"    ({report.faults_left_out} faults and stop requests between the first and the "
            f"last {len(report.fault_list) // 2} left out; --json lists the same)"
        )
    return "\n".join(lines)


def _histogram_lines(report: ShiftReport) -> list[str]:
    """The histogram's bins from the first to the last that holds a cycle, as bars."""
    cycle = report.cycle_times
    widest = max(*cycle.counts, cycle.under, cycle.over, 1)
    filled = [index for index, count in enumerate(cycle.counts) if count]
    rows = [(f"shorter than {cycle.low_s:.2f}", cycle.under)] if cycle.under else []
    for index in range(filled[0], filled[-1] + 1) if filled else ():
        low = cycle.low_s + index * cycle.bin_s
        rows.append((f"{low:8.2f} - {low + cycle.bin_s:<8.2f}", cycle.counts[index]))
    if cycle.over:
        high = cycle.low_s + len(cycle.counts) * cycle.bin_s
        rows.append((f"longer than {high:.2f}", cycle.over))
    return [f"    {label:>20} {n:7d} {'#' * round(40 * n / widest)}" for label, n in rows]


def _fault_line(report: ShiftReport, fault: Fault) -> str:
    where = fault.operation + (f"/{fault.step}" if fault.step not in (None, "connect") else "")
    if fault.started_halt:
        stood = f"stood {_duration(_stood_s(report, fault) or 0.0)}{_ENDED_BY[fault.ended_by]}"
    elif fault.operation == "connect":
        stood = "no session, no halt"
    else:
        stood = "while already halted"
    return (
        f"    {_clock(report, fault.time)}  {fault.status:<7} {where:<18} {stood}: {fault.reason}"
    )


def skipped_warning(report: ShiftReport) -> str | None:
    """One line naming what the report skipped (torn lines, unknown kinds), or None."""
    parts = []
    if report.torn:
        at = ", ".join(str(offset) for offset in report.torn_offsets)
        more = ", ..." if report.torn > len(report.torn_offsets) else ""
        parts.append(f"{report.torn} torn or non-JSON lines (at byte {at}{more})")
    if report.unknown_kinds:
        kinds = ", ".join(f"{name} x{n}" for name, n in report.unknown_kinds.items())
        parts.append(f"{sum(report.unknown_kinds.values())} records of unknown kinds ({kinds})")
    if report.bad_records:
        parts.append(f"{report.bad_records} records without an event or a readable timestamp")
    if not parts:
        return None
    return f"warning: report {report.path}: skipped " + "; ".join(parts)


def _stood_s(report: ShiftReport, fault: Fault) -> float | None:
    """How long the halt ``fault`` started lasted; one still open lasts to the report's end."""
    end = fault.halt_end if fault.halt_end is not None else report.end
    if not fault.started_halt or end is None:
        return None
    return max(0.0, end - fault.time)


def _iso(report: ShiftReport, t: float | None) -> str | None:
    return None if t is None else report.local(t).isoformat(timespec="seconds")


def _clock(report: ShiftReport, t: float | None) -> str:
    return "-" if t is None else report.local(t).strftime("%Y-%m-%d %H:%M:%S %z")


def _duration(seconds: float) -> str:
    minutes, secs = divmod(round(seconds), 60)
    hours, minutes = divmod(minutes, 60)
    return f"{hours}:{minutes:02d}:{secs:02d}"
