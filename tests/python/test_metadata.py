"""What a user or a packager reads about the project agrees with itself: the licence files the
Cargo manifest names exist, CITATION.cff is valid CFF 1.2.0 and names the version every FMU
reports (`version`, and `generationTool` with it), the changelog has that version, the README's
comparison is the one `make` measures, and the Makefile builds every variant synth knows."""
import ctypes
import json
import math
import os
import re
import shutil
import subprocess
import zipfile
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from readme_figures import disagreements, largest_share_of_tolerance

ROOT = Path(__file__).resolve().parents[2]
VENV_BIN = Path(__file__).resolve().parents[2] / ".venv" / "bin"


def crate_version(crate):
    text = (ROOT / crate / "Cargo.toml").read_text()
    return re.search(r'^version = "([^"]+)"', text, re.M).group(1)


def test_licence_files_match_the_manifest():
    manifest = (ROOT / "Cargo.toml").read_text()
    assert 'license = "MIT OR Apache-2.0"' in manifest
    assert "Permission is hereby granted, free of charge" in (ROOT / "LICENSE-MIT").read_text()
    assert "Apache License" in (ROOT / "LICENSE-APACHE").read_text()


def test_citation_is_valid_and_every_fmu_reports_its_version():
    version = crate_version("fmu-core")
    result = subprocess.run([str(VENV_BIN / "cffconvert"), "--validate", "-i", str(ROOT / "CITATION.cff")],
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr
    assert re.search(rf"^version: {re.escape(version)}$", (ROOT / "CITATION.cff").read_text(), re.M)
    assert f"## [{version}]" in (ROOT / "CHANGELOG.md").read_text()
    fmus = sorted((ROOT / "dist").glob("*.fmu"))
    assert len(fmus) >= 9
    for fmu in fmus:
        with zipfile.ZipFile(fmu) as z:
            root = ET.fromstring(z.read("modelDescription.xml"))
        assert root.get("generationTool") == f"suspension-fmus {version} (fmu-core)", fmu.name
        assert root.get("version").split("+")[0] == version, fmu.name


def block(text, tag):
    return text.split(f"<!-- {tag}:begin -->\n")[1].split(f"<!-- {tag}:end -->")[0]


def without_timing(table):
    """The table without its wall-time line, which differs from run to run."""
    return "\n".join(line for line in table.splitlines() if not re.match(r"^\d+ runs in [\d.]+ s", line))


# The report's sections the README carries (`make readme`), by marker.
REPORT_SECTIONS = {"comparison": "## Summary: W_k RMS seat acceleration [m/s²]",
                   "limits": "## Limits and model validity",
                   "split": "## Where the comfort comes from: body control and seat isolation",
                   "real-car": "## On a real car",
                   "orders": "## Master orders"}


def report_section(report, tag):
    return report.split(REPORT_SECTIONS[tag] + "\n")[1].split("\n## ")[0]


def readme_disagreements(tag, fresh):
    """How the README's block `tag` differs from the freshly measured text beyond the tolerance
    of `readme_figures` (the wall-time line left out: it differs from run to run)."""
    spliced = without_timing(block((ROOT / "README.md").read_text(), tag))
    return disagreements(spliced, without_timing(fresh))


def assert_readme_holds(tag, fresh, where):
    found = readme_disagreements(tag, fresh)
    spliced = without_timing(block((ROOT / "README.md").read_text(), tag))
    share = largest_share_of_tolerance(spliced, without_timing(fresh))
    print(f"README {tag} against {where}: the largest difference is {share:.0%} of its tolerance")
    assert not found, f"README {tag} disagrees with {where} (run `make readme`):\n" + "\n".join(found)


@pytest.mark.parametrize("tag", list(REPORT_SECTIONS))
def test_the_readme_comparison_is_the_measured_one(tag):
    """`make test` runs `master compare` first (results/report.md); `make readme` splices its
    summary and the runs it flags into the README. Words, flags and counts agree exactly, each
    figure within the stated tolerance (`readme_figures.py`: machines differ in the last digits)."""
    report = (ROOT / "results" / "report.md").read_text()
    assert_readme_holds(tag, report_section(report, tag), "results/report.md")


@pytest.mark.parametrize("tag,path", [("modes", "dist/car.md"), ("gamma", "dist/thesis/gamma.md")])
def test_the_readme_blocks_are_what_synth_writes(tag, path):
    """`synth` writes the modes of the car it designs for (dist/car.md) and, on the thesis's design
    file, what γ says about comfort (dist/thesis/gamma.md: each design's certified norm beside the
    passive car's on the same plant, and the comfort predicted beside the passive car's);
    `make readme` splices them."""
    assert_readme_holds(tag, (ROOT / path).read_text(), path)


def test_the_figure_check_takes_machine_differences_and_refuses_real_changes():
    """The figures two machines measured for the same commit (`hinf_of_aw` on `saturation`,
    the thesis designs' comfort range) agree; a changed figure, a changed flag or word, a changed
    count and a figure printed with other digits do not."""
    row = "| `hinf_of_aw` | 0.0037 (-98.0 %) | 0.4840 (-30.1 %) ⚠ |"
    assert disagreements(row, row.replace("0.4840", "0.4837")) == []
    gamma = "the predicted comfort 48.8–96.3 % better, 7 thesis designs, 0.0206 m/s²"
    assert disagreements(gamma, gamma.replace("48.8", "48.7").replace("0.0206", "0.0207")) == []
    for changed in [row.replace("0.4840", "0.4940"), row.replace("(-30.1 %)", "(-31.9 %)"),
                    row.replace(" ⚠", ""), row.replace("0.4840", "0.484")]:
        assert disagreements(row, changed), changed
    assert disagreements(gamma, gamma.replace("7 thesis", "6 thesis"))
    assert disagreements(gamma, gamma.replace("0.0206", "0.0216"))
    # A whole percentage is a figure to its units; a count is exact.
    whole = "the predicted comfort 48–96 % better, 7 thesis designs"
    assert disagreements(whole, whole.replace("48–", "49–")) == []
    assert disagreements(whole, whole.replace("48–", "51–"))
    assert disagreements(whole, whole.replace("7 thesis", "8 thesis"))


def native_blas_core():
    """The kernel family OpenBLAS picked for this CPU (Debian's build carries them all)."""
    lib = ctypes.CDLL("libopenblas.so.0")
    lib.openblas_get_corename.restype = ctypes.c_char_p
    return lib.openblas_get_corename().decode()


@pytest.fixture(scope="module")
def other_kernel_run(tmp_path_factory):
    """Every design synthesised again with OpenBLAS forced onto another CPU's kernels
    (`OPENBLAS_CORETYPE`, what differs between two machines), packed, and compared over the
    scenarios like `make`: another machine's run, made on this one (about 45 s)."""
    core = "Nehalem" if native_blas_core().lower() == "sandybridge" else "Sandybridge"
    out = tmp_path_factory.mktemp("other-kernel")
    env = dict(os.environ, OPENBLAS_CORETYPE=core)
    release = ROOT / "target" / "release"
    listed = lambda option: subprocess.run([str(release / "synth"), option], capture_output=True, text=True,
                                           check=True).stdout.split()
    variants = listed("--list")
    for design, folder, option in [("comfort", "designs", "--list"), ("thesis", "thesis", "--list-thesis")]:
        subprocess.run([str(release / "synth"), "--design", str(ROOT / "synth" / "designs" / f"{design}.json"),
                        "--out", str(out / folder), *listed(option)], env=env, check=True, capture_output=True)
    dist = out / "dist"
    dist.mkdir()
    for fmu in ["road", "plant"]:
        shutil.copy(ROOT / "dist" / f"{fmu}.fmu", dist)
    for v in variants:
        subprocess.run([str(release / "fmu-pack"), "fmu", "--lib", str(release / "libfmu_controller.so"),
                        "--resources", str(out / "designs" / v), "--out", str(dist / f"{v}.fmu")],
                       check=True, capture_output=True)
        # Beside its FMU as `make` puts it: the comparison reads a controller's role from it.
        shutil.copy(out / "designs" / f"{v}.certificate.json", dist)
    subprocess.run([str(release / "master"), "--dist", str(dist), "compare", "--scenarios", str(ROOT / "scenarios"),
                    "--controllers", ",".join(variants), "--out", str(out / "results"),
                    "--designs", str(out / "designs" / "synthesis.json")], check=True, capture_output=True)
    return core, out


def test_the_readme_figures_hold_against_another_machines_synthesis(other_kernel_run):
    """The README's figures hold for a synthesis on another machine's BLAS kernels, whose designs
    differ in their last digits (the output feedbacks' gains by up to 6e-4 relative, measured):
    the failure of `make test` on a fresh Intel machine, reproduced here. Where a saturated run
    carries that into the report's 4th digit (until 28 November `robust_of`'s, before it had its
    anti-windup: a check bit for bit then failed) the stated tolerance takes it, which
    `test_the_figure_check_takes_machine_differences_and_refuses_real_changes` holds on the
    figures two machines measured; here the designs must differ, or nothing was exercised."""
    core, out = other_kernel_run
    report = (out / "results" / "report.md").read_text()
    fresh = {tag: report_section(report, tag) for tag in REPORT_SECTIONS}
    gains = lambda root, v: json.loads((root / v / "controller.json").read_text())["C"]
    variants = [p.name for p in (out / "designs").iterdir() if (p / "controller.json").exists()]
    assert any(gains(out / "designs", v) != gains(ROOT / "dist", v) for v in variants), \
        f"OpenBLAS's {core} kernels gave this machine's designs bit for bit: the check is not exercised"
    for tag, text in fresh.items():
        assert_readme_holds(tag, text, f"a synthesis on OpenBLAS's {core} kernels")
    assert_readme_holds("gamma", (out / "thesis" / "gamma.md").read_text(), f"the thesis designs on {core} kernels")
    assert_readme_holds("modes", (out / "designs" / "car.md").read_text(), f"the car on {core} kernels")


def test_what_the_readme_says_around_the_gamma_figures_holds_on_every_thesis_certificate():
    """Every thesis design's norm peaks at the wheel hop (11.6 Hz on this car) and is pinned within
    10 % of the passive car's on the same plant (README "Why not γ")."""
    assert "passive car scores" in (ROOT / "dist" / "thesis" / "gamma.md").read_text()
    for cert in sorted((ROOT / "dist" / "thesis").glob("*.certificate.json")):
        c = json.loads(cert.read_text())
        assert 10.0 < c["peak_frequency_rad_s"] / (2 * math.pi) < 12.0, cert.name
        assert 0.9 * c["passive_norm"] < c["norm_upper"] <= c["passive_norm"] * (1 + 1e-6), cert.name


@pytest.mark.parametrize("makefile_list, option", [("CONTROLLERS", "--list"), ("THESIS_CONTROLLERS", "--list-thesis")])
def test_the_makefile_builds_every_variant_synth_lists(makefile_list, option):
    listed = subprocess.run([str(ROOT / "target" / "release" / "synth"), option], capture_output=True, text=True, check=True).stdout.split()
    line = re.search(rf"^{makefile_list} := (.*)$", (ROOT / "Makefile").read_text(), re.M).group(1)
    assert line.split() == listed
