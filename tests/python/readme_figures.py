"""Compare a figure block spliced into the README with the same block freshly measured, within a
stated tolerance instead of bit for bit.

Why a tolerance: the synthesis is not bit-reproducible across machines. OpenBLAS picks its kernels
by CPU, the SDP's bounds differ in their 9th digit from one machine (even one run) to the next, and
a saturated loop amplifies that: `hinf_of_aw` on `saturation` measured 0.4840 on one machine and
0.4837 on another (6.2e-4 relative). So the words, the table's shape and the flags must agree
exactly, and each number within

    |a - b| <= REL * scale + one unit in the last digit shown,

where `scale` is the number itself, or `|p| + 100` for a percentage `p` (a change relative to a
reference moves by REL * (|p| + 100) points when its figure moves by REL; a share of the time by at
most REL * 100), and the unit in the last digit covers a change of any size that flips a rounding.
Integers (counts, scenario names, ISO classes) must agree exactly, except a whole percentage,
which is a figure rounded to its units (the thesis designs' comfort range is printed so: its
least comfortable design, `delay_sf`, measured 47.8 % on this machine's kernels and 48.7 % on
Sandybridge's, a γ-suboptimal LMI solution the kernels move).

REL = 5e-3 is eight times the largest difference measured between two machines' syntheses:
6.2e-4, `hinf_of_aw` on `saturation`, both on the Intel machine that reported it and here with
OpenBLAS forced onto that machine's kernels (`test_metadata.py::
test_the_readme_figures_hold_against_another_machines_synthesis`, where the output feedbacks'
gains differ by up to 6e-4 relative). A real change of a design moves the figures by percents,
far outside it.
"""
import re

REL = 5e-3

# A decimal number, not part of a word (`W_k`, `hinf_of`, `2631`-style names stay text).
NUMBER = re.compile(r"(?<![\w.])[-+]?\d+(?:\.\d+)?(?![\w.])")
# What makes a number a percentage: a `%` after it, or after the range it opens.
PERCENT_AFTER = re.compile(r"\s?(?:–[-+]?\d+(?:\.\d+)?\s?)?%")


class Figure:
    """One number of a block: its value, the digits it was printed with, and whether a `%`
    follows it."""

    def __init__(self, match, text):
        token = match.group(0)
        self.token = token
        self.value = float(token)
        self.decimals = len(token.split(".")[1]) if "." in token else None
        # `12.5 %`, or the first bound of a range `48–96 %`.
        self.percent = PERCENT_AFTER.match(text, match.end()) is not None

    def tolerance(self, rel):
        if self.decimals is None and not self.percent:
            return 0.0
        scale = abs(self.value) + 100.0 if self.percent else abs(self.value)
        return rel * scale + 10.0 ** -(self.decimals or 0)


def split(text):
    """The block's words with every number replaced by `#`, and its numbers in order."""
    figures = [Figure(m, text) for m in NUMBER.finditer(text)]
    return NUMBER.sub("#", text), figures


def disagreements(spliced, fresh, rel=REL):
    """Every way the README's block differs from the fresh one beyond the tolerance, as
    sentences naming both figures (empty when they agree)."""
    words_a, figures_a = split(spliced.strip())
    words_b, figures_b = split(fresh.strip())
    if words_a != words_b:
        lines = zip(words_a.splitlines(), words_b.splitlines())
        first = next(((a, b) for a, b in lines if a != b), (words_a, words_b))
        return [f"the words differ (README / fresh): {first[0]!r} / {first[1]!r}"]
    found = []
    for a, b in zip(figures_a, figures_b):
        if a.decimals != b.decimals:
            found.append(f"{a.token} is printed with other digits than the fresh {b.token}")
            continue
        allowed = max(a.tolerance(rel), b.tolerance(rel))
        if abs(a.value - b.value) > allowed:
            found.append(f"README {a.token} against fresh {b.token}: differ by "
                         f"{abs(a.value - b.value):.3g}, more than the {allowed:.3g} allowed")
    return found


def largest_share_of_tolerance(spliced, fresh, rel=REL):
    """How close the two blocks come to disagreeing: the largest difference of two numbers as a
    share of what the tolerance allows them (0 when identical, above 1 when they disagree)."""
    _, figures_a = split(spliced.strip())
    _, figures_b = split(fresh.strip())
    worst = 0.0
    for a, b in zip(figures_a, figures_b):
        allowed = max(a.tolerance(rel), b.tolerance(rel))
        if a.value != b.value:
            worst = max(worst, abs(a.value - b.value) / allowed if allowed else float("inf"))
    return worst
