"""Helpers of bench/e2e_bench.py and its steps (e2e_fetch.py): log lines with
the load average, medians and spans, process CPU, free ports. Not run on
its own."""
import os
import resource
import socket
import statistics
from pathlib import Path

# The request every step times (README's figures).
LAYOUT, FRAMES, RESOLUTION = "hemi-octahedral", 12, 2048

LOADS = []


def log(msg):
    # Each line says how busy the machine was: on a shared machine a slow
    # step is often someone else's compile.
    LOADS.append(os.getloadavg()[0])
    print(f"{msg}  [load average {LOADS[-1]:.2f}]", flush=True)


def median(xs):
    return statistics.median(xs)


def span(xs, digits=2):
    return f"{min(xs):.{digits}f}–{max(xs):.{digits}f}"


def tail(path, n=15):
    try:
        lines = Path(path).read_text(errors="replace").splitlines()
    except OSError:
        return ""
    return "\n".join("    " + line for line in lines[-n:])


def children_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def proc_cpu(pid, with_children):
    """CPU seconds of a live process from /proc (children: those it reaped)."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    fields = text[text.rindex(")") + 2:].split()
    # After "pid (comm) ": state is fields[0]; utime..cstime are 11..14.
    ticks = int(fields[11]) + int(fields[12])
    if with_children:
        ticks += int(fields[13]) + int(fields[14])
    return ticks / os.sysconf("SC_CLK_TCK")


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]
