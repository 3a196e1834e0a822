"""Where tools/install-deps.sh puts the example-robot-data wheel's robot descriptions."""
import glob
import os


def robots_root(venv):
    """The wheel's robots/ folder in the venv @p venv, or None (after printing why) when the
    wheel is not installed: the caller then skips (exit 77)."""
    roots = glob.glob(os.path.join(venv, "lib", "python3*", "site-packages", "cmeel.prefix",
                                   "share", "example-robot-data", "robots"))
    if not roots:
        print("example-robot-data is not installed in", venv, "(tools/install-deps.sh)")
        return None
    return roots[0]
