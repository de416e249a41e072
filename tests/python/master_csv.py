"""Reading the CSV files `master run` and `master compare` write."""

import numpy as np


def header(path):
    """The columns of a master CSV as (name, unit) pairs: the header is `name [unit]`, the unit
    as the FMU declares it, or the bare name for a variable without one."""
    with open(path) as f:
        columns = f.readline().rstrip("\n").split(",")
    return [(c.split(" [")[0], c.split(" [")[1].rstrip("]") if " [" in c else "") for c in columns]


def read(path):
    """A master CSV as a structured array whose fields are the variable names, without units."""
    return np.genfromtxt(path, delimiter=",", skip_header=1, names=[n for n, _ in header(path)])
