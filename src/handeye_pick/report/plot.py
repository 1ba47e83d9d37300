"""The shift on one PNG for a supervisor: picks per hour with faults marked, the cycle-time
histogram, and the timeline of faults and halted stretches.

Times on the axes are local hours of the report's zone; cycle times are seconds. Rendering is
headless (a bare matplotlib ``Figure`` on the Agg canvas, no pyplot state), and matplotlib is
imported by ``render_report`` only.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from handeye_pick.errors import InputError
from handeye_pick.report.shift import ShiftReport, counted

if TYPE_CHECKING:
    from matplotlib.axes import Axes

FIGURE_SIZE_IN = (14.0, 8.0)
FIGURE_DPI = 100
_HALT_COLOUR = "tab:red"
_PICK_COLOUR = "tab:blue"
_STOP_COLOUR = "tab:orange"  # an operator's stop request: it halts, but is no fault


def render_report(report: ShiftReport, path: Path) -> None:
    """Write the report's picture as a PNG to ``path``; InputError when it cannot be written."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=FIGURE_SIZE_IN, dpi=FIGURE_DPI, layout="constrained")
    FigureCanvasAgg(fig)
    grid = fig.add_gridspec(2, 2, height_ratios=(3.0, 1.0), width_ratios=(2.0, 1.0))
    throughput = fig.add_subplot(grid[0, 0])
    _throughput(throughput, report)
    _timeline(fig.add_subplot(grid[1, 0], sharex=throughput), report)
    _cycle_times(fig.add_subplot(grid[:, 1]), report)
    statuses = report.statuses
    fig.suptitle(
        f"{report.path.name}: {counted(report.cycles, 'pick outcome')}, "
        f"{statuses['placed']} placed, {statuses['picked']} picked, {statuses['missed']} missed, "
        f"{statuses['no-candidate']} no candidate  |  {counted(report.faults, 'fault')}, "
        f"halted {100.0 * report.halted_share:.1f} % of the time",
        fontsize=13,
    )
    try:
        fig.savefig(path, format="png")
    except OSError as exc:
        raise InputError(f"report: writing the picture {path}: {exc.strerror or exc}") from None


def _hours(report: ShiftReport, t: float) -> float:
    """``t`` (s since the epoch) as hours since the first hour's start (the window's start
    when no hour has a cycle), the x axis of the throughput and the timeline."""
    origin = report.hours[0].start if report.hours else report.start
    return (t - (origin if origin is not None else t)) / 3600.0


def _hour_ticks(ax: Axes, report: ShiftReport) -> None:
    """Tick every hour bucket with its local clock time."""
    positions = [_hours(report, hour.start) for hour in report.hours]
    step = max(1, len(positions) // 12)  # at most a dozen labels
    ax.set_xticks(positions[::step])
    ax.set_xticklabels([report.local(h.start).strftime("%H:%M") for h in report.hours][::step])


def _throughput(ax: Axes, report: ShiftReport) -> None:
    from matplotlib.ticker import MaxNLocator

    ax.set_title("picks per hour (placed or picked)")
    positions = [_hours(report, hour.start) + 0.5 for hour in report.hours]
    picks = [hour.picks for hour in report.hours]
    ax.bar(positions, picks, width=0.9, color=_PICK_COLOUR)
    for x, hour in zip(positions, report.hours, strict=True):
        if hour.faults:
            ax.annotate(
                f"{hour.faults} fault" + ("s" if hour.faults > 1 else ""),
                (x, hour.picks),
                xytext=(0, 4),
                textcoords="offset points",
                ha="center",
                color=_HALT_COLOUR,
                fontsize=9,
            )
    _hour_ticks(ax, report)
    ax.tick_params(labelbottom=True)
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))  # whole picks, never 0.2 of one
    ax.set_ylabel("picks")
    ax.grid(True, axis="y", linewidth=0.3)


def _cycle_times(ax: Axes, report: ShiftReport) -> None:
    cycle = report.cycle_times
    ax.set_title("cycle time: completed pick to the next")
    if cycle.count == 0:
        # An empty histogram would draw a meaningless axis around zero.
        ax.text(
            0.5,
            0.5,
            "no cycle time: it needs two completed picks\nwith no fault or stop between them",
            transform=ax.transAxes,
            ha="center",
            va="center",
        )
        ax.set_axis_off()
        return
    edges = [cycle.low_s + index * cycle.bin_s for index in range(len(cycle.counts))]
    ax.bar(edges, cycle.counts, width=cycle.bin_s * 0.9, align="edge", color=_PICK_COLOUR)
    if cycle.median_s is not None and cycle.p90_s is not None:
        # The two labels on two rows: median and p90 are often a bin apart.
        lines = ((cycle.median_s, "median", "-", -14), (cycle.p90_s, "p90", "--", -28))
        for value, name, style, row in lines:
            ax.axvline(value, color="black", linestyle=style, linewidth=1.2)
            ax.annotate(
                f"{name} {value:.1f} s",
                (value, 1.0),
                xycoords=("data", "axes fraction"),
                xytext=(4, row),
                textcoords="offset points",
            )
    outside = [f"{n} {what}" for n, what in ((cycle.under, "shorter"), (cycle.over, "longer")) if n]
    if outside:
        ax.text(0.98, 0.95, ", ".join(outside), transform=ax.transAxes, ha="right")
    ax.set_xlabel("seconds")
    ax.set_ylabel("intervals")
    ax.grid(True, axis="y", linewidth=0.3)


def _timeline(ax: Axes, report: ShiftReport) -> None:
    ax.set_title("faults and stop requests (marks) and halted stretches (red bands)")
    end = report.end if report.end is not None else 0.0
    for fault in report.fault_list:
        x = _hours(report, fault.time)
        colour = _STOP_COLOUR if fault.status == "stopped" else _HALT_COLOUR
        ax.plot([x], [0.5], marker="v", color=colour, markersize=10)
        if fault.started_halt:
            until = fault.halt_end if fault.halt_end is not None else end
            ax.axvspan(x, max(x, _hours(report, until)), color=_HALT_COLOUR, alpha=0.3)
            ax.annotate(
                fault.step or fault.operation,
                (x, 0.5),
                xytext=(0, 8),
                textcoords="offset points",
                ha="center",
                fontsize=8,
            )
    right = max(_hours(report, end), len(report.hours), 1e-3)
    ax.set_xlim(min(0.0, _hours(report, report.start or end)), right)
    ax.set_yticks([])
    ax.set_xlabel("hour (local)")
