"""Shared start of the plotting scripts (plot_trajectory.py, bench_plots.py)."""
import os
import sys


def import_pyplot(script_name):
    """matplotlib.pyplot on the Agg backend. A python3 without matplotlib first on PATH (pyenv,
    venv) re-executes the calling script with the system /usr/bin/python3 once; returns None (after
    saying so on stderr) when no interpreter has matplotlib."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        return plt
    except ImportError:
        system = "/usr/bin/python3"
        if os.path.exists(system) and os.path.realpath(sys.executable) != os.path.realpath(system) \
                and not os.environ.get("DYGSLAM_PLOT_NO_REEXEC"):
            os.environ["DYGSLAM_PLOT_NO_REEXEC"] = "1"
            os.execv(system, [system] + sys.argv)
        print(script_name + ": python3-matplotlib is not installed", file=sys.stderr)
        return None
