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


def save_figure(fig, path, dpi):
    """Writes the figure as PNG to PATH: drawn into a new file of a random name in PATH's folder
    (made with O_EXCL: never a file or link that is there already), renamed over PATH when
    complete."""
    import tempfile
    out_dir = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".tmp.", suffix=".png",
                               dir=out_dir)
    try:
        umask = os.umask(0)
        os.umask(umask)
        os.fchmod(fd, 0o666 & ~umask)  # as a file the user makes (mkstemp's are 0600)
        with os.fdopen(fd, "wb") as f:
            fig.savefig(f, format="png", dpi=dpi)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
