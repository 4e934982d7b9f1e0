import os
import sys
import tempfile

sys.path.insert(0, os.path.dirname(__file__))


def pytest_configure(config):
    # The controller makes a folder where every worker (xdist) records what it compared, so the
    # totals can be printed at the end of the run whatever process did the comparing.
    if not hasattr(config, "workerinput") and "PNDISS_COUNTS_DIR" not in os.environ:
        os.environ["PNDISS_COUNTS_DIR"] = tempfile.mkdtemp(prefix="pndiss-counts-")


def record_count(what: str, n: int) -> None:
    """Add n to the total printed as 'WHAT: N' in the terminal summary."""
    d = os.environ.get("PNDISS_COUNTS_DIR")
    if d:
        with open(os.path.join(d, f"{os.getpid()}.txt"), "a", encoding="utf-8") as f:
            f.write(f"{what}\t{n}\n")


def record_names(what: str, names) -> None:
    """Add names to the set whose size is printed as 'WHAT: N' in the terminal summary (across workers)."""
    d = os.environ.get("PNDISS_COUNTS_DIR")
    if d:
        with open(os.path.join(d, f"{os.getpid()}.names"), "a", encoding="utf-8") as f:
            for n in names:
                f.write(f"{what}\t{n}\n")


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    if hasattr(config, "workerinput"):
        return
    d = os.environ.get("PNDISS_COUNTS_DIR")
    if not d or not os.path.isdir(d):
        return
    totals: dict[str, int] = {}
    sets: dict[str, set] = {}
    for name in sorted(os.listdir(d)):
        with open(os.path.join(d, name), encoding="utf-8") as f:
            for line in f:
                if name.endswith(".names"):
                    what, _, n = line.rstrip("\n").partition("\t")
                    sets.setdefault(what, set()).add(n)
                    continue
                what, _, n = line.rstrip("\n").rpartition("\t")
                totals[what] = totals.get(what, 0) + int(n)
    for what, names in sets.items():
        totals[what] = len(names)
    for what, n in sorted(totals.items()):
        terminalreporter.write_line(f"{what}: {n:,}")
